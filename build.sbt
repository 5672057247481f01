// Chisel generators for QP-solver cores for model predictive control.
ThisBuild / scalaVersion := "2.13.15"
ThisBuild / version      := "0.1.0"
ThisBuild / organization := "io.github.mpcfpga"

val chiselVersion = "6.7.0"

lazy val root = (project in file("."))
  .settings(
    name := "mpc-cores",
    libraryDependencies ++= Seq(
      "org.chipsalliance" %% "chisel" % chiselVersion,
      "com.lihaoyi" %% "ujson" % "3.1.0"
    ),
    scalacOptions ++= Seq("-language:reflectiveCalls", "-deprecation", "-feature", "-Xcheckinit", "-Ymacro-annotations"),
    addCompilerPlugin("org.chipsalliance" % "chisel-plugin" % chiselVersion cross CrossVersion.full)
  )
