package linalg

import chisel3._
import float.{FAdd, FloatFormat, Stages}

/** Pairwise floating-point sum of a vector of words, the order of DotProductTree and of the golden models: pairs
  * (0,1), (2,3), ... at each level, an odd last element passed on delayed to stay aligned; latAdd cycles per level,
  * latAdd ceil(log2 n) in all.
  */
object FAddTree {
  def apply(terms: Seq[UInt], fmt: FloatFormat, latAdd: Int): UInt = {
    require(terms.nonEmpty, "FAddTree: no terms")
    var level = terms
    while (level.length > 1) {
      level = level.grouped(2).toSeq.map {
        case Seq(x, y) =>
          val add = Module(new FAdd(fmt, latAdd))
          add.in_valid := true.B
          add.a        := x
          add.b        := y
          add.sub      := false.B
          add.out
        case Seq(x) => Stages.delay(x, latAdd)
      }
    }
    level.head
  }
}
