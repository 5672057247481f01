package float

/** Generator entry point:
  * `runMain float.FloatMain <op> <expW> <manW> <latency|default|steps> <target> <outDir> [... more groups of six]`.
  * `steps`: one register after every step, the fully pipelined operator (its highest clock rate). `target`
  * (dsp.Target): ecp5 puts the multiplier's significand product on a MULT18X18D with its registers.
  * Writes <outDir>/<module>.sv (a FloatTop test wrapper around the operator) and <outDir>/float.json
  * (module, format, latency, port layout) per group. Each group is checked on its own: a refusal prints
  * `REFUSED <group>: <rule and values>` and the others still build; the exit code is 1 if any was refused.
  */
object FloatMain extends App {
  require(args.length >= 6 && args.length % 6 == 0,
    "usage: float.FloatMain <op> <expW> <manW> <latency|default|steps> <target> <outDir> [...groups of six]")

  val refused = args.grouped(6).toSeq.flatMap { case Array(op, e, m, l, t, out) =>
    val what = s"$op $e $m $l $t"
    try {
      FloatOp.check(op)
      def int(nm: String, s: String) =
        s.toIntOption.getOrElse(throw new IllegalArgumentException(s"$nm must be an integer: got '$s'"))
      val fmt = FloatFormat(int("expW", e), int("manW", m))
      val target = dsp.Target(t)
      // on a MULT18X18D the product takes a cycle more (the DSP's pipeline register)
      val extra = if (op == "mul" && FMul.onDsp(fmt, target)) 1 else 0
      val lat = l match {
        case "default" => FloatOp.defaultLatency(op, fmt) + extra
        case "steps"   => FloatOp.steps(op, fmt) + extra
        case _         => int("latency", l)
      }
      require(lat >= 0, s"latency must be >= 0: got latency=$lat")
      val name = s"FloatTop_${op}_${fmt.tag}_l$lat" + (if (extra > 0) s"_${target.name}" else "")
      gen.Emit.systemVerilog(new FloatTop(op, fmt, lat, target), out, name)
      gen.Emit.writeText(s"$out/float.json", json(op, fmt, lat, name, target, extra))
      None
    } catch {
      case ex: IllegalArgumentException =>
        println(s"REFUSED $what: ${ex.getMessage}")
        Some(what)
    }
  }
  if (refused.nonEmpty) sys.exit(1)

  def json(op: String, fmt: FloatFormat, lat: Int, name: String, target: dsp.Target, extra: Int): String = {
    val o = ujson.Obj(
      "op" -> op,
      "module" -> name,
      "sv" -> s"$name.sv",
      "expW" -> fmt.expW,
      "manW" -> fmt.manW,
      "width" -> fmt.width,
      "bias" -> fmt.bias,
      "latency" -> lat,
      "target" -> target.name,
      "steps" -> (FloatOp.steps(op, fmt) + extra),
      "default_latency" -> (FloatOp.defaultLatency(op, fmt) + extra),
      "out_width" -> math.max(fmt.width, 4),
      "op_input" -> (op match { case "add" => "sub"; case "cmp" => "signaling"; case _ => "unused" }),
      "out_bits" -> (if (op == "cmp") ujson.Arr("lt", "eq", "le", "unordered") else ujson.Str("result")),
      "flags" -> ujson.Arr("invalid", "divByZero", "overflow", "underflow", "inexact"),
      "rounding" -> "nearest-even",
      "subnormals" -> "supported (gradual underflow); tininess detected before rounding",
      "nan" -> s"canonical quiet NaN 0x${fmt.qNaN.toString(16)}"
    )
    ujson.write(o, indent = 2)
  }
}
