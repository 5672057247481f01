package gen

/** Readers of the config.json the Python front ends write: integer words (JSON numbers, exact below 2^53) as
  * BigInt, matrices of them, and small integers. */
object ConfigJson {
  def ints(v: ujson.Value): Seq[BigInt] = v.arr.toSeq.map(x => BigInt(x.num.toLong))
  def mat(v: ujson.Value): Seq[Seq[BigInt]] = v.arr.toSeq.map(ints)
  def small(v: ujson.Value): Seq[Int] = v.arr.toSeq.map(_.num.toInt)
}
