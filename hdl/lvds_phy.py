"""The LVDS receiver's PHYs: the ECP5 one (:class:`LvdsEcp5`) and the registry of every PHY
(:data:`PHYS`; the lane-side ports of each: :func:`tdicam.hdl.lvds.lane_ports`).

A PHY is the receiver core :class:`tdicam.hdl.lvds.LvdsRx` (training, bitslip, deskew) behind
a device's input primitives: ``none`` the core itself (the deserializers' words in, the
delay taps out: the simulated generic PHY), ``xilinx7`` :class:`tdicam.hdl.lvds.LvdsXilinx`
(IBUFDS, IDELAYE2, ISERDESE2), ``ecp5`` :class:`LvdsEcp5` (LVDS input, DELAYF, IDDRX2F,
ECLKSYNCB, CLKDIVF). The simulation models of the primitives are
:mod:`tdicam.cosim.xilinx7_io` and :mod:`tdicam.cosim.ecp5_io`.
"""

from amaranth.hdl import Array, Cat, ClockDomain, ClockSignal, Const, Instance, Module, Mux, \
    ResetSignal, Signal
from amaranth.lib import fifo, wiring
from amaranth.lib.cdc import ResetSynchronizer
from amaranth.lib.wiring import In, Out

from tdicam.errors import check_range
from tdicam.hdl.lvds import TAP_BITS, LvdsRx, LvdsXilinx, eye_ports, forward_core, lane_ports, \
    rx_ports
from tdicam.hdl.util import quiet_reject

__all__ = ["LvdsEcp5", "PHYS", "TRACKING_WORD_BITS", "DELAYF_STEP_PS", "ECP5_STEPS", "tap_ps", "pin_ports",
           "pin_clocks", "derived_clocks", "SCLK_DIV"]

#: DELAYF's delay step (ps) and the number of its counts (0..127).
DELAYF_STEP_PS = 25.0
_DELAYF_COUNTS = 128
#: DELAYF steps per training tap of the ECP5 PHY (default): 4 x 25 ps = 100 ps, 32 taps = 3.2
#: ns, one bit at 300 Mb/s.
ECP5_STEPS = 4


#: CLKDIVF's division of the edge clock: ``SCLK = ECLK / SCLK_DIV`` (x2 gearing).
SCLK_DIV = 2

#: The I/O standard of the ECP5 PHY's pins (each an LVDS pair: the port is its P pin).
LVDS_INPUT = {"IO_TYPE": "LVDS"}


class LvdsEcp5(wiring.Component):
    """:class:`~tdicam.hdl.lvds.LvdsRx` behind ECP5 input primitives (FPGA-TN-02035).

    Per lane: the ``lane_p`` pin (an LVDS pair: constrain it ``IO_TYPE=LVDS``,
    ``DIFFRESISTOR=100``; its N pin is the pair's other pin, not a port) -> ``DELAYF``
    (``USER_DEFINED``, count ``tap x steps``, 25 ps a count) -> ``IDDRX2F`` (x2 gearing: four
    bits a ``SCLK`` cycle, ``Q0`` the first) -> a fabric gearbox of four bits a ``SCLK`` cycle
    into ``word_bits``-bit words (first bit in the MSB) -> one asynchronous FIFO (all lanes)
    into the word clock ``clk`` -> the core's ``lane_raw``. ``clk_eclk`` (half the bit rate:
    150 MHz for 300 Mb/s) drives ``ECLKSYNCB`` -> the edge clock ``ECLK`` and ``CLKDIVF``
    (``DIV = "2.0"``) -> ``SCLK`` = ``ECLK / 2``; ``clk`` must come from the same PLL at
    ``ECLK * 2 / word_bits`` (30 MHz for 10-bit, 25 MHz for 12-bit words at 300 Mb/s).

    DELAYF has no load: the delay moves one count per ``MOVE`` pulse. A controller per lane
    turns the trainer's tap loads into pulses (one count every two word clocks, towards
    ``tap x steps``) and holds the trainer's step counter while the delay moves
    (:class:`~tdicam.hdl.lvds.LaneTrainer` ``hold``), so each step's ``settle`` words start
    when the delay has arrived: training takes longer than the golden step count by the
    moves (up to 2 x 31 x ``steps`` word clocks for the jump to the chosen tap). ``LOADN``
    follows the reset (the delay restarts at count 0 with the controller).

    No eye tracking (``track``): :class:`~tdicam.hdl.lvds_track.LaneTracker` needs a second
    sampler of each lane at a delay of its own (the monitor), and this PHY has one input
    path a lane (the pair's receiver -> DELAYF -> IDDRX2F). The delay line is not what
    blocks it: a tracker's one-tap step is ``steps`` DELAYF moves, two word clocks each, made
    while data flows, as the controller already moves it. A monitor needs a second DELAYF
    and IDDRX2F fed from the same pair's receiver, which this PHY does not build (whether
    the device routes a pair's receiver to its complementary pin's input logic is not
    established here; the 7-series PHY has it: ``IBUFDS_DIFF_OUT``).

    Parameters
    ----------
    lanes, word_bits, settle, min_run, pick, deskew_depth
        :class:`~tdicam.hdl.lvds.LvdsRx`'s.
    eye : bool
        The eye status (:func:`~tdicam.hdl.lvds.eye_ports`).
    steps : 1..4
        DELAYF counts per training tap (the tap is ``steps x 25`` ps; 31 taps must stay
        within the 127 counts).

    Attributes
    ----------
    lane_p : In(lanes)
        The lanes' pins.
    clk_eclk : In(1)
        The edge clock's source.
    (and every register and status port of :class:`~tdicam.hdl.lvds.LvdsRx`)
    """

    @quiet_reject
    def __init__(self, *, lanes=8, word_bits=10, settle=8, min_run=9, pick=5,
                 deskew_depth=8, steps=ECP5_STEPS, eye=False):
        self._steps = check_range("steps", steps, 1, (_DELAYF_COUNTS - 1) // 31)
        self._core = LvdsRx(lanes=lanes, word_bits=word_bits, settle=settle, min_run=min_run,
                            pick=pick, deskew_depth=deskew_depth, hold=True, eye=eye)
        ports = lane_ports("ecp5", lanes, word_bits)
        ports.update(rx_ports(lanes, word_bits))
        if eye:
            ports.update(eye_ports(lanes, word_bits))
        super().__init__(ports)

    #: The device pins among the ports ({port: I/O attributes}): the lanes and the edge
    #: clock's source, LVDS inputs.
    PINS = {"lane_p": LVDS_INPUT, "clk_eclk": LVDS_INPUT}

    @property
    def core(self):
        return self._core

    @property
    def steps(self):
        return self._steps

    @property
    def tap_ps(self):
        """The training tap (ps): ``steps x 25``."""
        return self._steps * DELAYF_STEP_PS

    def elaborate(self, platform):
        m = Module()
        core = self._core
        m.submodules.core = core
        n, w = core.lanes, core.word_bits
        forward_core(m, self, core)
        rst = ResetSignal("sync")
        eclk, sclk = Signal(), Signal()
        m.submodules.eclksync = Instance("ECLKSYNCB", i_ECLKI=self.clk_eclk, i_STOP=Const(0),
                                         o_ECLKO=eclk)
        m.submodules.clkdiv = Instance("CLKDIVF", p_DIV=f"{SCLK_DIV:.1f}", i_CLKI=eclk,
                                       i_RST=Const(0), i_ALIGNWD=Const(0), o_CDIVX=sclk)
        m.domains.sclk = ClockDomain("sclk", local=True)
        m.d.comb += ClockSignal("sclk").eq(sclk)
        m.submodules.sclk_reset = ResetSynchronizer(rst, domain="sclk")

        nibbles = []
        for i in range(n):
            move, direction, z = (Signal(name=f"move{i}"), Signal(name=f"direction{i}"),
                                  Signal(name=f"dly{i}"))
            m.submodules[f"delayf{i}"] = Instance(
                "DELAYF", p_DEL_MODE="USER_DEFINED", p_DEL_VALUE=0, i_A=self.lane_p[i],
                i_LOADN=~rst, i_MOVE=move, i_DIRECTION=direction, o_Z=z,
                o_CFLAG=Signal(name=f"cflag{i}"))
            q = [Signal(name=f"q{i}_{j}") for j in range(4)]
            m.submodules[f"iddr{i}"] = Instance(
                "IDDRX2F", i_D=z, i_SCLK=sclk, i_ECLK=eclk, i_RST=ResetSignal("sclk"),
                i_ALIGNWD=Const(0), **{f"o_Q{j}": q[j] for j in range(4)})
            nibbles.append(Cat(q[3], q[2], q[1], q[0]))       # Q0 (the first bit) the MSB
            # the delay controller: one count per two word clocks towards tap x steps
            ld = core.lane_ld[i]
            tap = core.lane_tap[i * TAP_BITS:(i + 1) * TAP_BITS]
            target, cur = Signal(7, name=f"target{i}"), Signal(7, name=f"count{i}")
            with m.If(ld):
                m.d.sync += target.eq(tap * self._steps)
            m.d.sync += move.eq(0)
            with m.If(~ld & ~move & (cur != target)):
                m.d.sync += [move.eq(1), direction.eq(target < cur)]
            with m.If(move):
                m.d.sync += cur.eq(Mux(direction, cur - 1, cur + 1))
            m.d.comb += core.lane_hold[i].eq(ld | move | (cur != target))

        # four bits a SCLK cycle -> words (all lanes share the bit count)
        held = Signal(range(w + 4))
        total = held + 4
        emit = total >= w
        words = []
        for i in range(n):
            acc = Signal(w + 3, name=f"acc{i}")
            new = Cat(nibbles[i], acc[:w - 1])
            m.d.sclk += acc.eq(new)
            words.append(Array(new[s:s + w] for s in range(4))[total - w])
        m.d.sclk += held.eq(Mux(emit, total - w, total))
        m.submodules.cdc = cdc = fifo.AsyncFIFO(width=n * w, depth=8, w_domain="sclk",
                                                r_domain="sync")
        m.d.comb += [cdc.w_data.eq(Cat(*words)), cdc.w_en.eq(emit)]
        # read from three words on: the writes come in bursts (2 words in 5 SCLK cycles for
        # 10 bits), the reads one a word clock: the FIFO never runs dry after that
        started, raw = Signal(), Signal(n * w)
        with m.If(~started & (cdc.r_level >= 3)):
            m.d.sync += started.eq(1)
        m.d.comb += cdc.r_en.eq(started)
        with m.If(started & cdc.r_rdy):
            m.d.sync += raw.eq(cdc.r_data)
        m.d.comb += core.lane_raw.eq(raw)
        return m


#: Every PHY: {name: receiver class}.
PHYS = {"none": LvdsRx, "xilinx7": LvdsXilinx, "ecp5": LvdsEcp5}
#: The device PHYs that track the eyes (``track``) and the word size each needs: the
#: 7-series' monitor sampler is the N pin's IDELAYE2 -> ISERDESE2 path, a free one with
#: 12-bit words (:class:`tdicam.hdl.lvds.LvdsXilinx`); the ECP5 PHY has none.
TRACKING_WORD_BITS = {"xilinx7": 12}


def tap_ps(phy):
    """The training tap (ps) of ``phy``'s delay line (None for the generic PHY: the link
    model's own tap)."""
    from tdicam.model.lvds import XILINX_TAP_PS
    return {"none": None, "xilinx7": XILINX_TAP_PS, "ecp5": ECP5_STEPS * DELAYF_STEP_PS}[phy]


def pin_ports(phy):
    """The device pins among the lane-side ports of ``phy`` ({port: I/O attributes}, e.g.
    ``IO_TYPE``); empty for a PHY whose ports are not pins of one device."""
    return dict(getattr(PHYS[phy], "PINS", None) or {})


def pin_clocks(phy, word_mhz, word_bits):
    """The clocks among ``phy``'s pins ({port: MHz}) at ``word_mhz`` words of ``word_bits``
    bits a lane: the ECP5 PHY's edge clock ``clk_eclk`` at half the bit rate (DDR)."""
    if phy == "ecp5":
        return {"clk_eclk": word_mhz * word_bits / 2}
    return {}


def derived_clocks(phy, word_mhz, word_bits):
    """The clocks ``phy`` derives inside the device from its pin clocks ({domain: MHz}; the
    place-and-route tool constrains them itself): the ECP5 PHY's ``sclk``, ``ECLK /
    SCLK_DIV`` through CLKDIVF (75 MHz for 300 Mb/s)."""
    if phy == "ecp5":
        return {"sclk": pin_clocks(phy, word_mhz, word_bits)["clk_eclk"] / SCLK_DIV}
    return {}
