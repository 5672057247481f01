package fgm

import chisel3._
import chisel3.util._
import bus.{AxiLiteIO, AxiLiteResp, AxiLiteSlave, AxiStreamIO}
import fixed.FixedOps
import linalg.{DotProductParams, DotProductTree}
import mem.InitRam

/** Fixed-point fast gradient method (Algorithm 1 of 002) for input-constrained MPC, after Fig. 1/2 of 002.
  *
  * One solve: receive w = (x, r) on s_axis (saturated to the state box), compute h = Phi_n w once (first pass),
  * then Imax iterations of
  *   t = (I - H_n) y - h,  z+ = proj(t),  y+ = (1 + beta) z+ - beta z,
  * each in L_F = ceil(n/P) + l_A ceil(log2 n) + 2 l_M + 3 l_A + 1 cycles, and send u0 (or all of z) on m_axis.
  *
  * P row units share the operand vector y; unit p computes rows p, p+P, ... one per cycle. A row's dot product,
  * subtraction, projection and y update form a pipeline; new y components collect in yNext and move to the
  * operand register y when the iteration's last row is done (the +1 of eq. (23)).
  */
class FgmCore(val p: FgmParams) extends Module {
  override def desiredName = p.moduleName

  /** w = (x, r), one signed word with frac_bits fraction bits per beat, tlast on the last */
  val s_axis = IO(Flipped(new AxiStreamIO(p.streamW)))
  /** u0 (nu words) or z (n words), same word format, tlast on the last */
  val m_axis = IO(new AxiStreamIO(p.streamW))
  /** configuration, status and the data memories */
  val s_axil = IO(Flipped(new AxiLiteIO(p.axiAddrW)))

  import p.{K, P, m, n, nu, nw}
  val b = p.fracBits

  // ------------------------------------------------------------------ control and status registers
  val ctrlWarm   = RegInit(p.warmDefault.B)
  val ctrlHold   = RegInit(false.B)
  val ctrlOutAll = RegInit(p.outAllDefault.B)
  val imaxReg    = RegInit(p.imaxDefault.U(16.W))
  val stSat      = RegInit(false.B)
  val stOvf      = RegInit(false.B)
  val stRej      = RegInit(false.B)
  val stTlast    = RegInit(false.B)
  val warmValid  = RegInit(false.B)
  val solves     = RegInit(0.U(32.W))
  val lastCycles = RegInit(0.U(32.W))

  // ------------------------------------------------------------------ memories
  val kW = math.max(1, log2Ceil(2 * K))
  val matRam = (0 until P).map { u =>
    Module(new InitRam(s"${p.moduleName}_mat$u", 2 * K, m, p.coefW, p.matInit(u), outReg = true))
  }
  val bndRam = (0 until P).map { u =>
    Module(new InitRam(s"${p.moduleName}_ubox$u", K, 2, p.zW, p.boundInit(u), outReg = true))
  }
  val xboxRam = Module(new InitRam(s"${p.moduleName}_xbox", nw, 2, p.xW, p.xlo.zip(p.xhi).map { case (l, h) => Seq(l, h) }))
  val betaRam = Module(new InitRam(s"${p.moduleName}_beta", 1, 2, p.betaW, Seq(Seq(p.beta, p.onePlusBeta))))
  for (r <- matRam ++ bndRam :+ xboxRam :+ betaRam) {
    r.io.clock := clock
    r.io.wen   := false.B
    r.io.waddr := 0.U
    r.io.wmask := 0.U
    r.io.wdata := 0.U
  }
  betaRam.io.raddr := 0.U
  val betaQ = betaRam.io.rdata(p.betaW - 1, 0).asSInt
  val opbQ  = betaRam.io.rdata(2 * p.betaW - 1, p.betaW).asSInt

  // ------------------------------------------------------------------ input stream: w, saturated to the box
  val inBuf  = Reg(Vec(nw, SInt(p.xW.W)))
  val inCnt  = RegInit(0.U(log2Ceil(nw + 1).W))
  val inFull = RegInit(false.B)
  s_axis.tready := !inFull && !(ctrlHold && inCnt === 0.U)
  xboxRam.io.raddr := Mux(s_axis.fire && inCnt =/= (nw - 1).U, inCnt + 1.U, Mux(s_axis.fire, 0.U, inCnt))
  val xlo = xboxRam.io.rdata(p.xW - 1, 0).asSInt
  val xhi = xboxRam.io.rdata(2 * p.xW - 1, p.xW).asSInt
  when(s_axis.fire) {
    val (v, clamped) = FixedOps.clamp(s_axis.tdata.asSInt, xlo, xhi)
    inBuf(inCnt) := v(p.xW - 1, 0).asSInt
    when(clamped) { stSat := true.B }
    val last = inCnt === (nw - 1).U
    when(s_axis.tlast =/= last) { stTlast := true.B }
    inCnt := Mux(last, 0.U, inCnt + 1.U)
    when(last) { inFull := true.B }
  }

  // ------------------------------------------------------------------ solver state
  val sIdle :: sRun :: sOut :: Nil = Enum(3)
  val state   = RegInit(sIdle)
  val hPhase  = RegInit(false.B)
  val cnt     = RegInit(0.U(log2Ceil(p.cyclesPerIteration + 1).W))
  val iter    = RegInit(0.U(16.W))
  val imaxL   = RegInit(1.U(16.W))
  val warmL   = RegInit(false.B)
  val outAllL = RegInit(false.B)
  val outCnt  = RegInit(0.U(log2Ceil(n + 1).W))
  val busyCyc = RegInit(0.U(32.W))

  val wReg  = Reg(Vec(nw, SInt(p.xW.W)))
  val yReg  = Reg(Vec(n, SInt(p.yW.W)))
  val yNext = Reg(Vec(n, SInt(p.yW.W)))
  val zReg  = Reg(Vec(n, SInt(p.zW.W)))
  // Per row unit, in the order the unit visits its rows: h = Phi_n w and the previous iterate z. Each is a
  // rotating FIFO (Fig. 1 of 002), read at its head, so no row needs a K-way multiplexer.
  val hFifo = Seq.fill(P)(Reg(Vec(K, SInt(p.sumW.W))))
  val zFifo = Seq.fill(P)(Reg(Vec(K, SInt(p.zW.W))))

  // Fetch: a token per matrix row follows the row down the pipeline. tokN is the token of the next cycle, from
  // the sequencer's next state: the row RAMs are addressed one cycle ahead and their outputs registered, so the
  // block RAM clock-to-output delay stays off the datapath without adding cycles.
  class Token extends Bundle {
    val valid = Bool()
    val h     = Bool() // first pass (h = Phi_n w)
    val first = Bool() // row of the first iteration
    val k     = UInt(math.max(1, log2Ceil(K)).W)
  }
  val kW0  = math.max(1, log2Ceil(K))
  val tokN = Wire(new Token)
  tokN       := 0.U.asTypeOf(new Token)
  when(state === sIdle && inFull) {
    tokN.valid := true.B
    tokN.h     := true.B
  }.elsewhen(state === sRun && hPhase) {
    tokN.valid := true.B
    tokN.h     := cnt =/= (K - 1).U
    tokN.first := cnt === (K - 1).U
    tokN.k     := Mux(cnt === (K - 1).U, 0.U, cnt + 1.U)
  }.elsewhen(state === sRun) {
    val wrap = cnt === (p.cyclesPerIteration - 1).U
    tokN.valid := Mux(wrap, iter =/= imaxL - 1.U, cnt + 1.U < K.U)
    tokN.first := iter === 0.U && !wrap
    tokN.k     := Mux(wrap, 0.U, (cnt + 1.U)(kW0 - 1, 0))
  }
  val tok0 = RegNext(tokN, 0.U.asTypeOf(new Token))
  def tokAt(stage: Int): Token =
    if (stage < 0) tokN else ShiftRegister(tok0, stage, 0.U.asTypeOf(new Token), true.B)
  val tok1    = tokAt(1)
  val tokSum  = tokAt(p.stageSum)
  val tokT    = tokAt(p.stageT)
  val tokZ    = tokAt(p.stageZ)
  val tokY    = tokAt(p.stageY)
  val tokBnd  = tokAt(p.stageT - 2)
  val tokYsub = tokAt(p.stageZ + p.latMul)

  for (u <- 0 until P) {
    matRam(u).io.raddr := Mux(tokN.h, K.U +& tokN.k, tokN.k)
    bndRam(u).io.raddr := Mux(tokN.valid && tokN.h, tokN.k, tokBnd.k)
  }

  val yPad = VecInit((0 until m).map(j => if (j < n) yReg(j).pad(p.opW) else 0.S(p.opW.W)))
  val wPad = VecInit((0 until m).map(j => if (j < nw) wReg(j).pad(p.opW) else 0.S(p.opW.W)))
  val ovfNow = Wire(Vec(P, Bool()))

  val dp = Module(new DotProductTree(DotProductParams(m, p.coefW, p.opW, p.sumW, b, p.latMul, p.latAdd, p.rounding)))
  val unitY = Wire(Vec(P, SInt(p.yW.W)))
  val unitZ = Wire(Vec(P, SInt(p.zW.W)))
  val unitCold = Wire(Vec(P, SInt(p.zW.W)))
  val units = (0 until P).map { u =>
    val tree = if (u == 0) dp else Module(new DotProductTree(dp.p))
    tree.io.inValid := tok1.valid
    tree.io.coef    := matRam(u).io.rdata.asTypeOf(Vec(m, SInt(p.coefW.W)))
    tree.io.op      := Mux(tok1.h, wPad, yPad)

    // First pass: h = Phi_n w enters the FIFO one row per cycle; each iteration row reads the head and rotates.
    val hHead = hFifo(u)(0)
    when(tokSum.valid) {
      for (i <- 0 until K - 1) hFifo(u)(i) := hFifo(u)(i + 1)
      hFifo(u)(K - 1) := Mux(tokSum.h, tree.io.sum, hHead)
    }

    // Cold start z0 = proj(0), from this row's bounds during the first pass.
    val lo1 = bndRam(u).io.rdata(p.zW - 1, 0).asSInt
    val hi1 = bndRam(u).io.rdata(2 * p.zW - 1, p.zW).asSInt
    unitCold(u) := Mux(!lo1(p.zW - 1) && lo1 =/= 0.S, lo1, Mux(hi1(p.zW - 1), hi1, 0.S))

    // t = (I - H_n) y - h
    val (t, ofT) = FixedOps.satSub(tree.io.sum, hHead, p.tW)
    val tD       = ShiftRegister(t, p.latAdd)
    // z+ = proj(t) on [lo, hi] of this row
    val proj = Module(new BoxProjection(p.tW, p.zW, p.latAdd))
    proj.io.in := tD
    proj.io.lo := bndRam(u).io.rdata(p.zW - 1, 0).asSInt
    proj.io.hi := bndRam(u).io.rdata(2 * p.zW - 1, p.zW).asSInt
    val z = proj.io.out
    // y+ = (1 + beta) z+ - beta z, z the previous iterate of the same row: the head of the z FIFO, which the
    // first iteration loads from the z0 registers (rows u, u+P, ...) as it reads it.
    val load = tok1.valid && tok1.first && tok1.k === 0.U
    val zSrc = VecInit((0 until K).map { i =>
      val r = i * P + u
      Mux(load, if (r < n) zReg(r) else 0.S(p.zW.W), zFifo(u)(i))
    })
    val zOld = zSrc(0)
    val rotZ = tokZ.valid && !tokZ.h
    when(load || rotZ) {
      for (i <- 0 until K) zFifo(u)(i) := Mux(rotZ, if (i < K - 1) zSrc(i + 1) else z, zSrc(i))
    }
    val pa        = FixedOps.mulPipelined(opbQ, z, p.latMul)
    val pb        = FixedOps.mulPipelined(betaQ, zOld, p.latMul)
    val ra        = FixedOps.shiftRound(pa, b, p.rounding)
    val rb        = FixedOps.shiftRound(pb, b, p.rounding)
    val (y, ofY)  = FixedOps.satSub(ra, rb, p.yW)
    unitY(u) := ShiftRegister(y, p.latAdd)
    unitZ(u) := ShiftRegister(z, p.latMul + p.latAdd)

    // Saturation anywhere in a live row sets the sticky overflow flag.
    val ofTree = tree.io.outValid && tree.io.overflow
    val ofTs   = tokSum.valid && !tokSum.h && ofT
    val ofYs   = tokYsub.valid && !tokYsub.h && ofY
    ovfNow(u) := ofTree || ofTs || ofYs
  }
  when(ovfNow.asUInt.orR) { stOvf := true.B }

  // Register writes: z0 = y0 at the start (warm: the previous solution shifted by one stage, the last stage
  // repeated, Fig. 2b) or in the first pass (cold), y+/z+ at the end of each row's pipeline, the operand copy.
  // Both decided a cycle ahead and registered: they fan out to every row register.
  val copyNow  = RegNext(state === sRun && !hPhase && cnt === (p.cyclesPerIteration - 1).U && iter =/= imaxL - 1.U,
    false.B)
  val startNow = state === sIdle && inFull
  val warmNow  = ctrlWarm && warmValid
  val warmCopy = RegNext(startNow && warmNow, false.B)
  for (r <- 0 until n) {
    val u   = r % P
    val k   = r / P
    val src = if (r < n - nu) r + nu else r
    when(warmCopy) {
      yReg(r) := zReg(src).pad(p.yW)
      zReg(r) := zReg(src)
    }.elsewhen(tok1.valid && tok1.h && tok1.k === k.U && !warmL) {
      yReg(r) := unitCold(u).pad(p.yW)
      zReg(r) := unitCold(u)
    }.elsewhen(copyNow) {
      yReg(r) := yNext(r)
    }
    when(tokY.valid && !tokY.h && tokY.k === k.U) {
      yNext(r) := unitY(u)
      zReg(r)  := unitZ(u)
    }
  }

  // ------------------------------------------------------------------ sequencer
  switch(state) {
    is(sIdle) {
      when(inFull) {
        inFull  := false.B
        wReg    := inBuf
        state   := sRun
        hPhase  := true.B
        cnt     := 0.U
        iter    := 0.U
        imaxL   := imaxReg
        warmL   := warmNow
        outAllL := ctrlOutAll
        busyCyc := 0.U
      }
    }
    is(sRun) {
      busyCyc := busyCyc + 1.U
      when(hPhase) {
        when(cnt === (K - 1).U) {
          hPhase := false.B
          cnt    := 0.U
        }.otherwise { cnt := cnt + 1.U }
      }.otherwise {
        when(cnt === (p.cyclesPerIteration - 1).U) {
          cnt  := 0.U
          iter := iter + 1.U
          when(iter === imaxL - 1.U) {
            state  := sOut
            outCnt := 0.U
          }
        }.otherwise { cnt := cnt + 1.U }
      }
    }
    is(sOut) {
      when(m_axis.fire) {
        val last = outCnt === Mux(outAllL, (n - 1).U, (nu - 1).U)
        outCnt := outCnt + 1.U
        when(last) {
          state      := sIdle
          solves     := solves + 1.U
          lastCycles := busyCyc
          warmValid  := true.B
        }
      }
    }
  }
  m_axis.tvalid := state === sOut
  m_axis.tdata  := zReg(outCnt).pad(p.streamW).asUInt
  m_axis.tlast  := outCnt === Mux(outAllL, (n - 1).U, (nu - 1).U)

  // ------------------------------------------------------------------ AXI4-Lite register file
  val axil = Module(new AxiLiteSlave(p.axiAddrW))
  axil.axi <> s_axil
  val busy     = state =/= sIdle || inFull || inCnt =/= 0.U
  val statusW  = Cat(warmValid, stTlast, stRej, stOvf, stSat, busy)
  val rdA      = axil.rd.addr
  axil.rd.resp := AxiLiteResp.OKAY
  axil.rd.data := 0.U
  switch(rdA) {
    is(FgmRegs.ID.U) { axil.rd.data := FgmRegs.IdValue.U }
    is(FgmRegs.CONFIG0.U) { axil.rd.data := Cat(P.U(16.W), n.U(16.W)) }
    is(FgmRegs.CONFIG1.U) { axil.rd.data := Cat(nu.U(8.W), b.U(8.W), nw.U(16.W)) }
    is(FgmRegs.CTRL.U) { axil.rd.data := Cat(ctrlOutAll, ctrlHold, ctrlWarm) }
    is(FgmRegs.IMAX.U) { axil.rd.data := imaxReg }
    is(FgmRegs.STATUS.U) { axil.rd.data := statusW }
    is(FgmRegs.SOLVES.U) { axil.rd.data := solves }
    is(FgmRegs.LAST_CYCLES.U) { axil.rd.data := lastCycles }
    is(FgmRegs.CYCLES_PER_ITER.U) { axil.rd.data := p.cyclesPerIteration.U }
  }
  // The data memories are write-only.
  when(rdA >= FgmRegs.BETA.U) { axil.rd.resp := AxiLiteResp.DECERR }

  val wA   = axil.wr.addr
  val wD   = axil.wr.data
  val wSig = wD.asSInt
  axil.wr.resp := AxiLiteResp.OKAY
  def fitsS(w: Int): Bool = wSig >= FixedOps.minOf(w).S(32.W) && wSig <= FixedOps.maxOf(w).S(32.W)
  def inRegion(nm: String): Bool = wA >= p.regionBase(nm).U && wA < (p.regionBase(nm) + p.regionSizes.toMap.apply(nm)).U

  def dataWrite(fitW: Int, ok: Bool)(body: => Unit): Unit = {
    when(busy) {
      axil.wr.resp := AxiLiteResp.SLVERR
      when(axil.wr.valid) { stRej := true.B }
    }.elsewhen(!ok) {
      axil.wr.resp := AxiLiteResp.DECERR
    }.elsewhen(!fitsS(fitW)) {
      axil.wr.resp := AxiLiteResp.SLVERR
      when(axil.wr.valid) { stRej := true.B }
    }.otherwise {
      when(axil.wr.valid) { body }
    }
  }

  when(wA === FgmRegs.CTRL.U) {
    when(axil.wr.valid) {
      ctrlWarm   := wD(0)
      ctrlHold   := wD(1)
      ctrlOutAll := wD(2)
    }
  }.elsewhen(wA === FgmRegs.IMAX.U) {
    when(wD === 0.U || wD > 65535.U) {
      axil.wr.resp := AxiLiteResp.SLVERR
    }.elsewhen(axil.wr.valid) { imaxReg := wD }
  }.elsewhen(wA === FgmRegs.STATUS.U) {
    when(axil.wr.valid) {
      when(wD(1)) { stSat := false.B }
      when(wD(2)) { stOvf := false.B }
      when(wD(3)) { stRej := false.B }
      when(wD(4)) { stTlast := false.B }
    }
  }.elsewhen(wA === FgmRegs.BETA.U || wA === FgmRegs.ONE_PLUS_BETA.U) {
    dataWrite(p.betaW, true.B) {
      betaRam.io.wen   := true.B
      betaRam.io.wmask := Mux(wA === FgmRegs.BETA.U, 1.U, 2.U)
      betaRam.io.wdata := Fill(2, wD(p.betaW - 1, 0))
    }
  }.elsewhen(inRegion("XBOX")) {
    val off = wA - p.regionBase("XBOX").U
    val j   = off >> 1
    dataWrite(p.xW, j < nw.U) {
      xboxRam.io.wen   := true.B
      xboxRam.io.waddr := j
      xboxRam.io.wmask := UIntToOH(off(0), 2)
      xboxRam.io.wdata := Fill(2, wD(p.xW - 1, 0))
    }
  }.elsewhen(inRegion("UBOX")) {
    val off  = wA - p.regionBase("UBOX").U
    val slot = off >> 1
    val unit = if (p.pBits == 0) 0.U else slot(p.pBits - 1, 0)
    val k    = slot >> p.pBits
    dataWrite(p.zW, unit < P.U && (k * P.U + unit) < n.U) {
      for (u <- 0 until P) {
        when(unit === u.U) {
          bndRam(u).io.wen   := true.B
          bndRam(u).io.waddr := k
          bndRam(u).io.wmask := UIntToOH(off(0), 2)
          bndRam(u).io.wdata := Fill(2, wD(p.zW - 1, 0))
        }
      }
      warmValid := false.B
    }
  }.elsewhen(inRegion("MAT_A") || inRegion("MAT_F")) {
    val isF  = inRegion("MAT_F")
    val off  = wA - Mux(isF, p.regionBase("MAT_F").U, p.regionBase("MAT_A").U)
    val col  = if (p.cBits == 0) 0.U else off(p.cBits - 1, 0)
    val slot = off >> p.cBits
    val unit = if (p.pBits == 0) 0.U else slot(p.pBits - 1, 0)
    val k    = slot >> p.pBits
    val cols = Mux(isF, nw.U, n.U)
    dataWrite(p.coefW, unit < P.U && (k * P.U + unit) < n.U && col < cols) {
      for (u <- 0 until P) {
        when(unit === u.U) {
          matRam(u).io.wen   := true.B
          matRam(u).io.waddr := Mux(isF, k +& K.U, k)
          matRam(u).io.wmask := UIntToOH(col, m)
          matRam(u).io.wdata := Fill(m, wD(p.coefW - 1, 0))
        }
      }
    }
  }.otherwise {
    axil.wr.resp := AxiLiteResp.DECERR
  }
}

/** Register word addresses (byte address = 4 x word address). */
object FgmRegs {
  val IdValue         = 0x46474d31L // "FGM1"
  val ID              = 0
  val CONFIG0         = 1
  val CONFIG1         = 2
  val CTRL            = 3
  val IMAX            = 4
  val STATUS          = 5
  val SOLVES          = 6
  val LAST_CYCLES     = 7
  val CYCLES_PER_ITER = 8
  val BETA            = 9
  val ONE_PLUS_BETA   = 10
  val Reserved        = 11
}
