"""The scene schema: every section's dataclass, its keys, defaults and physical bounds.

A scene is a TOML file (read with :mod:`tomllib`) that describes the platform motion, the
target and its light level, the sensor, TDI, motion errors, the processing pipeline and how
to run the simulation. :func:`load_scene` validates it completely and returns a frozen
:class:`Scene`; every error is one line that names the offending key, e.g.
``[sensor].read_noise_e: must be >= 0, got -1``. Unknown sections and keys are errors, with
a did-you-mean hint when a valid name is close.

Schema (every key is optional unless marked *required*; defaults in brackets)
------------------------------------------------------------------------------
Exactly one of ``[orbit]`` and ``[turntable]``:

``[orbit]``
    ``altitude_km`` *required*, 0..100000; ``gsd_m`` *required*, ground sample distance,
    0.001..100000 m.
    Line period ``T1 = gsd / v_g`` (Qu et al. 2010 eqs 4-5).
``[turntable]``
    ``angular_speed_rad_s`` *required*, 1e-6..1000; ``distance_m`` *required*,
    sensor-to-axis distance, 0.001..1000 m. Line period ``T_line = a / (omega l)`` with
    ``a`` the sensor pitch (Tao et al. 2012 eq 5).

The line period either gives must lie in 1e-8..100 s.

``[target]``
    ``kind`` ["flat"]: one of ``image``, ``bars``, ``edge``, ``siemens``, ``flat``.
    ``signal_e`` [1000.0], 0..1e12: the light level, as the electrons one pixel collects in one
    exposure (one line period, one stage) from the brightest part of the target (image value
    1.0, bright bar, bright side of the edge; a flat target is uniform at this level).
    Chart keys, only with their kind: ``contrast`` [1.0] (bars, edge, siemens), Michelson
    contrast in (0, 1] — the dark level is ``signal_e (1 - c) / (1 + c)``; ``period_px``
    [8.0] (bars), bar period in output pixels, >= 2 and at most half the output's extent
    along ``direction`` (``[run].lines`` or ``[sensor].columns``); ``direction``
    ["along_track"] (bars), the axis the bar pattern varies along, ``along_track`` or
    ``cross_track``; ``profile``
    ["square"] (bars), ``square`` bars or a ``sine`` grating (one spatial frequency, for
    measuring the MTF at exactly ``1/period_px``); ``angle_deg``
    [5.0] (edge), slant of the edge from the cross-track axis, in [-45, 45]; ``spokes`` [36]
    (siemens), number of spoke pairs, 4..720. ``kind = "image"`` needs exactly one of
    ``image`` (a bundled scikit-image picture, see :data:`BUNDLED_IMAGES`) or ``path`` (a
    PNG or TIFF file, relative to the scene file; it must exist and is read when the scene
    is: at least 8 x 8 pixels, grey, grey + alpha, RGB or RGBA with an opaque alpha, no
    negative values; the conversion to grey levels is
    :mod:`tdicam.model.physics.targets`'s).

``[sensor]``
    ``columns`` [1280], ``rows`` [1024]: 1..65536. ``pitch_um`` [5.5], 0.1..1000.
    ``fill_factor`` [1.0]: area fill factor in (0, 1]; the aperture MTF uses
    ``q/p = sqrt(fill_factor)`` (square active area). ``bits`` [12]: ADC bits, 1..24.
    ``full_well_e`` [20000], 1..1e9. ``conversion_gain_e_per_dn`` [full_well_e / 2**bits],
    1e-6..1e9: electrons per DN at channel gain 1 (a channel of gain g has ``conversion / g`` e-/DN).
    Impairments default to zero so that a scene simulates only what it asks for:
    ``read_noise_e`` [0], 0..1e6 (RMS), ``dark_current_e_per_s`` [0], 0..1e12, ``prnu`` [0]
    (fraction, 0.015 = 1.5 %, in [0, 1)), ``dsnu_e`` [0], 0..1e6 (RMS). ``shutter``
    ["rolling"]: ``rolling`` or ``global`` (global assumed pipelined). ``black_level_dn``
    [0], >= 0 and < 2**bits: ADC offset (pedestal) added to every sample, so that read noise
    around a dark level is not clipped at code 0.
    Row timing (optional): ``pixel_clock_mhz`` (0.001..1e6, pixels per second over all
    channels, in MHz) and ``row_blanking_us`` [3.5, Tao et al. 2012's typical value], 0..1e6, only
    with ``pixel_clock_mhz``, give ``T_row = t_rb + columns / f_s``; or
    ``max_frame_rate_hz`` (0.001..1e9, the datasheet full-frame rate) gives
    ``T_row = 1 / (rows F)``; not both. With a row time the window
    limit ``M0`` is known (Tao et al. 2012 eq 13). ``gains`` [[1.0]]: one gain, or two as
    ``[high, low]`` with high > low (Ning et al. 2019: ``[4.9, 0.8]``), each > 0.
``[sensor.lvds]`` (optional; without it the lanes are ideal and no link is simulated)
    The sensor's serial LVDS lanes (:mod:`tdicam.model.lvds_front`; defaults the GMAX0504 of
    Ning et al. 2019): ``lanes_per_gain`` [40], 1..128, at most ``columns`` (at most 128 lanes
    in all the gains a merging block takes: 64 a gain with hdr; every lane sends
    ``ceil(columns / lanes_per_gain)`` pixel words a line, a lane with a column fewer a
    padded last slot); ``word_bits``
    [12], 10 or 12, >= ``bits`` (with ``bits = word_bits`` the all-ones code is the sync
    word: full scale is sent as ``2**bits - 2``); ``bit_rate_mbps`` [300], 1..2000;
    ``mapping`` ["interleaved"], the only one: lane ``g L + k`` carries columns ``k, k+L,
    ...`` of gain channel ``g`` (high-gain lanes first); ``train_word`` [0xB92 / 0x2E4], its
    ``word_bits`` rotations all different; ``tap_ps`` [156.25], 1..1000, the IDELAY tap;
    ``eye_centre_taps`` [16], 0..31, and ``eye_width_taps``, 0..UI/tap: each a number or one
    per lane (``lanes_per_gain x`` gains); ``jitter_ps`` [0], 0..UI. The link (training of
    every lane) is simulated only when ``eye_width_taps`` or ``jitter_ps`` is given; a lane
    that cannot train (no run of 9 taps) has its columns invalid (0 and reported).
    ``eye_status`` [false]: the receiver publishes its training (per lane the pass mask over
    the 32 taps, the chosen tap and slip, the eye width found) and checks every bit with
    walking-1/0 patterns the sensor sends after lock; ``tdicam run`` reports them
    (``eyes.png``, report.json's ``rtl.eyes``). Opt-in: it adds ports to the pipeline top.
    ``drift_taps`` [0], -31..31, a number or one per lane: each eye's centre moves by that
    many taps (+: to higher taps) over ``drift_frames`` [20], >= 1, frames as the sensor
    sends them (from its first frame on; :class:`tdicam.model.lvds.Lane` drift), as
    temperature moves it over an orbit; ``tracking`` [false]: the receiver follows each
    locked lane's eye with a monitor sampler (:mod:`tdicam.hdl.lvds_track`: the generic
    PHY of the chain's co-simulation; from serial bits with ``[run.rtl] phy = "xilinx7"``
    and 12-bit words, any other PHY refused with tracking) and reports every correction. Without tracking a drift past the sampling tap's margin
    puts the lane in error.

``[optics]`` (optional)
    ``psf_sigma_px`` [0], >= 0: standard deviation of a Gaussian optics PSF in pixels (0: a
    perfect lens; the optics effect is skipped).

``[tdi]``
    ``stages`` [1]: an integer >= 1, or a non-empty list of them (a sweep, each value
    once); each must not
    exceed ``[sensor].rows`` nor ``M0`` when the row timing gives one; digital TDI takes at
    most 128 stages and, unless an hdr merge feeds it, 8..14-bit pixels (``[sensor].bits``):
    the golden accumulator's limits, the same for every fidelity. ``domain``
    ["digital"]: ``digital`` or ``charge``. ``direction`` ["forward"]: ``forward`` or
    ``reverse``. ``output`` ["full"]: ``full`` (``bits + ceil(log2 m)`` bits) or
    ``saturate`` to ``output_bits`` [= ``[sensor].bits``], 1..32.

``[motion]``
    ``dv_over_v`` [0.0]: relative velocity mismatch, a number or a non-empty list (a
    sweep, each value once), each in (-1, 1). ``drift_deg`` [0.0]: drift (crab) angle, in (-90, 90).

``[pipeline]``
    ``blocks`` [["tdi"]]: the ordered processing chain from ``cds``, ``nuc``, ``hdr``,
    ``tdi``, ``median3``; ``tdi`` exactly once, no repeats; ``cds``, ``nuc`` and ``hdr``
    act on single exposures, so they come before ``tdi`` and in that order; ``median3`` may
    come before or after ``tdi``. ``output`` ["stream"]: where the generated top's
    pixels go: ``"stream"``, the last block's AXI4-Stream (``m_axis``); ``"links"``, the
    camera's output links of ``[camera]`` (needed): a frame selector keeping one image in
    ``K = frame_rate_hz / output_frame_rate_hz`` (a whole number, else a one-line error),
    then ``links`` TLK2711 framers of ``link_pixel_bits`` a pixel
    (:class:`tdicam.hdl.tlk2711.Tlk2711`, pins ``link<k>_txd``/``_tklsb``/``_tkmsb``) in
    the link clock's domain (ports ``link_clk``/``link_rst``, ``link_clock_mhz``). An
    image is a frame of the chain's output (median3 frames the run's lines: the sensor's
    rows, or a cut's lines), or with single-line frames the sensor's rows of them; the
    links learn a frame's end from the chain's frame markers (the next ``first``). Block
    options, only for listed blocks:
    ``[pipeline.cds]`` ``reset_level_dn`` [0.0], >= 0 and < 2**bits;
    ``[pipeline.nuc]`` ``gain_frac_bits`` [12], 4..16 (the golden model's range), ``ecc``
    [true] (the coefficients pass a 64/72 SECDED round trip without faults), ``flash``
    ["none"]: ``"nand"`` stores them in a 4 Gb NAND flash (MT29F4G08 geometry, the camera's
    calibration store: bad-block scan, block map, 64/72 ECC pages, default coefficients
    gain 1 / offset 0 for a word with an uncorrectable error) and loads them back
    (:func:`tdicam.model.nand_store.store_roundtrip`), with ``ecc`` true and ``gain_frac_bits``
    <= 14 (16-bit gain words); its faults: ``bad_blocks`` [0] random factory bad blocks,
    0..4095 (never block 0), ``flip_single`` / ``flip_double`` [0.0] probability that a
    coefficient word gets one / two flipped bits, each in 0..1 and their sum <= 1, ``seed``
    [1] >= 0 (the faults' random numbers; channel ``k`` of a dual-gain sensor uses
    ``seed + k``);
    ``[pipeline.hdr]`` ``threshold_dn`` [3/4 of full scale], 1..2**bits-1, ``band_dn``
    [64], 1..threshold_dn, ``slope_frac_bits`` [8], 0..16;
    ``[pipeline.tdi]`` ``memory`` ["auto"]: where the gateware keeps TDI's partial sums:
    ``chip`` (block RAM), ``ddr`` (the DDR of ``[ddr]``) or ``auto`` (DDR when they exceed
    the FPGA's block RAM); a pipeline that spills to DDR needs a ``[ddr]`` section (the
    golden chain and the scene simulator are the same either way);
    ``[pipeline.median3]`` ``edge_enhance`` [false].

``[ddr]`` (optional)
    The DDR memory beside the FPGA that a pipeline may spill to: ``interface`` ["mig"], the
    controller's user interface (``mig``: Xilinx MIG-style ``app_*`` ports, 64-bit words;
    the pipeline top's simulation puts a model of the controller behind it); ``base`` [0],
    byte address of the first buffer, a multiple of 8 below 2**28. Without it a pipeline
    whose memory must spill is an error. Co-simulation only (the gateware is the same): the
    stall pattern of the simulation controller model behind the top's DDR ports,
    ``refresh_period`` [780] cycles between refreshes, ``refresh_cycles`` [44] of each
    (below ``refresh_period``), ``lat_lo`` [20] .. ``lat_hi`` [60] cycles of read latency
    (2..1000), ``drop`` [16]: each ready dropped with probability drop/256 (0..255). The
    longest stall, ``refresh_cycles + lat_hi``, also sizes the sensor front end's crossing
    FIFO (``[sensor.lvds]``).

``[camera]`` (optional)
    The whole camera's rate budget that ``tdicam plan`` prints (lanes, processing clock,
    DDR interfaces, NAND load, output links; :mod:`tdicam.planning.camera`): the keys,
    their defaults (the camera of Ning et al. 2019), bounds and meaning are
    :data:`tdicam.model.physics.camera.KEYS`. ``frame_rate_hz`` defaults to
    ``[sensor].max_frame_rate_hz`` (one of the two is needed), ``output_frame_rate_hz`` to
    ``frame_rate_hz`` and not above it; ``links`` must divide ``[sensor].columns``. The
    golden chain does not read it; the gateware reads the links' keys and the frame rates'
    ratio only with ``[pipeline].output = "links"``.

``[run]``
    ``lines`` [256]: output lines, >= 1, with ``columns x lines`` at most 2**27 output
    pixels (the simulator holds them in memory). ``seed`` [0] >= 0. ``fidelity`` ["auto"]:
    ``exact`` (quantize every exposure), ``fast`` (aggregate) or ``auto`` (fast when its
    error is below ``tolerance``). ``tolerance`` [0.01]: largest relative RMS error of the
    fast aggregate, in (0, 1).
``[run.rtl]`` (optional)
    ``crop`` [whole frame]: ``[x0, y0, width, height]`` of the output to simulate
    cycle-accurately, inside ``columns x lines``. ``simulator`` ["verilator"]: ``icarus``
    or ``verilator``. ``pixels_per_clock`` [1]: 1, 2, 4 or 8 pixels per beat of the
    whole-chain top's input and of every block up to TDI (a block after TDI's ``m`` stages
    gets ``m`` times fewer pixels a second and runs at ``ppc / m``, at least 1, behind a
    width converter), dividing the crop's width (without a crop,
    ``[sensor].columns``); also the default ``--ppc`` of ``tdicam verilog|synth|export
    pipeline``. ``lane_dies`` [none]: ``[lane, frame]``, with ``[sensor.lvds]``: in the
    co-simulation the sensor's lane ``lane`` dies in the middle of ``frame`` (the frames the
    sensor sends, from 0, reset frames included: then a signal frame, odd); the camera's
    controller retrains the lanes after the next two frames (the scene simulator's frames
    are those of a healthy link). Needs
    ``[tdi].domain = "digital"`` (charge-domain TDI has no gateware chain).

The reader that validates a file into these (and the cross-section checks) is
:mod:`tdicam.scene.loader`; its :class:`~tdicam.scene.loader.Scene` holds one of each.

Layer: part of :mod:`tdicam.scene`; imports the block registry (the pipeline's block names
and their option sets) and the planning physics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from tdicam.blocks import scene_blocks
from tdicam.model.physics import plan as _plan

__all__ = ["BOUNDS", "BUNDLED_IMAGES", "TARGET_KINDS", "BLOCKS", "DDR_INTERFACES", "FIDELITIES", "Orbit",
           "Turntable", "TargetSpec", "Lvds", "Sensor", "Optics", "Tdi", "Motion", "Ddr", "Pipeline",
           "RtlRun", "Run"]

#: Pictures shipped inside scikit-image (``skimage.data.<name>()``), usable as
#: ``[target].image``.
BUNDLED_IMAGES = ("astronaut", "brick", "camera", "chelsea", "clock", "coffee", "coins",
                  "grass", "gravel", "horse", "moon", "page", "text")
#: Values of ``[target].kind``.
TARGET_KINDS = ("image", "bars", "edge", "siemens", "flat")
#: Names allowed in ``[pipeline].blocks``: the registry's blocks with a scene rank
#: (:func:`tdicam.blocks.scene_blocks`), in that order.
BLOCKS = tuple(b.name for b in scene_blocks())

#: Physical bounds ``"section.key": (lo, hi)``, inclusive, of the quantities whose schema
#: would otherwise only ask for a positive or non-negative value, and of the sensor's
#: integer sizes (the keys ``tdicam plan`` has options for). They exclude absurd input
#: (a 1e12 km orbit, a 1e-300 m GSD, a turntable at 1e-12 rad/s, 1e30 electrons) whose
#: arithmetic is garbage, and nothing a real camera or lab rig does. ``tdicam plan --help``
#: states them for its options; the module docstring states them for the scene keys.
BOUNDS = {
    "orbit.altitude_km": (0, 100_000),          # ground to 2.8 x geostationary
    "orbit.gsd_m": (1e-3, 100_000),
    "turntable.angular_speed_rad_s": (1e-6, 1000),
    "turntable.distance_m": (1e-3, 1000),
    "target.signal_e": (0, 10**12),
    "sensor.columns": (1, 65536),
    "sensor.rows": (1, 65536),
    "sensor.bits": (1, 24),
    "sensor.pitch_um": (0.1, 1000),
    "sensor.full_well_e": (1, 10**9),
    "sensor.conversion_gain_e_per_dn": (1e-6, 10**9),
    "sensor.read_noise_e": (0, 10**6),
    "sensor.dark_current_e_per_s": (0, 10**12),
    "sensor.dsnu_e": (0, 10**6),
    "sensor.row_blanking_us": (0, 10**6),
    "sensor.pixel_clock_mhz": (1e-3, 10**6),
    "sensor.max_frame_rate_hz": (1e-3, 10**9),
}

#: ``[ddr].interface``: the DDR controllers a pipeline can spill through.
DDR_INTERFACES = ("mig",)

# --------------------------------------------------------------------------------------
# dataclasses
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Orbit:
    """Circular orbit: ``altitude_km`` (>= 0) and ground sample distance ``gsd_m`` (> 0)."""

    altitude_km: float
    gsd_m: float

    @property
    def ground_speed_m_s(self) -> float:
        """Ground-track speed, m/s (Qu et al. 2010 eq 4)."""
        return float(_plan.ground_speed(self.altitude_km * 1e3))

    @property
    def line_period_s(self) -> float:
        """Line period ``gsd / v_g``, seconds (Qu et al. 2010 eq 5)."""
        return float(_plan.line_period(self.gsd_m, self.ground_speed_m_s))


@dataclass(frozen=True)
class Turntable:
    """Turntable rig: ``angular_speed_rad_s`` (> 0) and sensor-to-axis ``distance_m`` (> 0)."""

    angular_speed_rad_s: float
    distance_m: float


@dataclass(frozen=True)
class TargetSpec:
    """What the camera looks at and how bright it is (see the module docstring).

    Keys that do not apply to ``kind`` are None.
    """

    kind: str
    signal_e: float
    image: str | None = None
    path: Path | None = None
    period_px: float | None = None
    contrast: float | None = None
    direction: str | None = None
    profile: str | None = None
    angle_deg: float | None = None
    spokes: int | None = None


@dataclass(frozen=True)
class Lvds:
    """``[sensor.lvds]``: the sensor's serial lanes (see the module docstring). ``eye_*`` and
    ``skew_bits`` are one value per lane (``skew_bits`` empty: 0 on every lane); ``simulate`` is whether the link is simulated (an eye or jitter
    given)."""

    lanes_per_gain: int
    word_bits: int
    bit_rate_mbps: float
    mapping: str
    train_word: int
    tap_ps: float
    eye_centre_taps: tuple
    eye_width_taps: tuple
    jitter_ps: float
    simulate: bool
    skew_bits: tuple = ()
    eye_status: bool = False
    drift_taps: tuple = ()
    drift_frames: int = 20
    tracking: bool = False


@dataclass(frozen=True)
class Sensor:
    """The CMOS area sensor (see the module docstring for units and defaults)."""

    columns: int
    rows: int
    pitch_um: float
    fill_factor: float
    bits: int
    full_well_e: float
    conversion_gain_e_per_dn: float
    read_noise_e: float
    dark_current_e_per_s: float
    prnu: float
    dsnu_e: float
    shutter: str
    row_blanking_us: float
    pixel_clock_mhz: float | None
    max_frame_rate_hz: float | None
    gains: tuple[float, ...]
    black_level_dn: float = 0.0
    lvds: Lvds | None = None

    @property
    def pitch_m(self) -> float:
        """Pixel pitch in metres."""
        return self.pitch_um * 1e-6

    @property
    def q_over_p(self) -> float:
        """Active width over pitch for the aperture MTF, ``sqrt(fill_factor)``."""
        return math.sqrt(self.fill_factor)

    @property
    def full_scale_dn(self) -> int:
        """Largest ADC code, ``2**bits - 1``."""
        return (1 << self.bits) - 1

    @property
    def row_time_s(self) -> float | None:
        """Row read time from the pixel clock or the frame rate; None when neither is given."""
        if self.pixel_clock_mhz is not None:
            return float(_plan.row_time(self.row_blanking_us * 1e-6, self.columns,
                                        self.pixel_clock_mhz * 1e6))
        if self.max_frame_rate_hz is not None:
            return float(_plan.row_time_from_frame_rate(self.max_frame_rate_hz, self.rows))
        return None

    @property
    def available_frame_rate_hz(self) -> float | None:
        """Full-frame rate ``1 / (rows T_row)``; None without row timing."""
        t = self.row_time_s
        return None if t is None else 1.0 / (self.rows * t)


@dataclass(frozen=True)
class Optics:
    """``[optics]``: Gaussian PSF standard deviation in pixels (0: none)."""

    psf_sigma_px: float = 0.0


@dataclass(frozen=True)
class Tdi:
    """TDI settings; ``stages`` is always a tuple (one entry unless the scene sweeps)."""

    stages: tuple[int, ...]
    domain: str
    direction: str
    output: str
    output_bits: int

    @property
    def max_stages(self) -> int:
        """The largest stage count of the sweep."""
        return max(self.stages)


@dataclass(frozen=True)
class Motion:
    """Motion errors; ``dv_over_v`` is always a tuple (one entry unless the scene sweeps)."""

    dv_over_v: tuple[float, ...]
    drift_deg: float


@dataclass(frozen=True)
class Ddr:
    """``[ddr]``: the DDR user interface a pipeline's spill uses (``DDR_INTERFACES``);
    ``stalls``: the simulation controller model's stall settings given away from their
    defaults, ((key, value), ...)."""

    interface: str = "mig"
    base: int = 0
    stalls: tuple = ()


@dataclass(frozen=True)
class Pipeline:
    """Ordered block chain and the options of each block (``scene.pipeline.<block>``: the
    block's :class:`tdicam.blocks.Options` dataclass, its defaults when not given).

    ``options`` holds ``(block, options)`` pairs of every block with a ``[pipeline.<block>]``
    section, listed or not."""

    blocks: tuple[str, ...]
    options: tuple = ()
    output: str = "stream"

    def __getattr__(self, name):
        # scene.pipeline.<block>: the block's options (dunder and private names are not
        # options: copy and pickle look those up before the fields exist)
        if not name.startswith("_") and name != "options":
            for block, opts in self.options:
                if block == name:
                    return opts
        raise AttributeError(f"{type(self).__name__!s} has no attribute {name!r}")

    def after_lines(self, block) -> bool | None:
        """True/False when ``block`` runs after/before the line-making block (TDI); None when
        it is not listed."""
        if block not in self.blocks:
            return None
        line_block = next(b.name for b in scene_blocks() if b.pipeline.lines)
        return self.blocks.index(block) > self.blocks.index(line_block)


@dataclass(frozen=True)
class RtlRun:
    """``[run.rtl]``: cycle-accurate crop ``(x0, y0, width, height)`` (None = whole frame);
    ``lane_dies``: ``(lane, frame)`` a sensor lane that dies in the co-simulation, or None;
    ``phy``: the device PHY checked from serial bits beside the chain ("generic": none);
    ``csr``: the top with its control bus, its status read through it."""

    crop: tuple[int, int, int, int] | None
    simulator: str
    pixels_per_clock: int
    lane_dies: tuple[int, int] | None = None
    phy: str = "generic"
    csr: bool = False


#: The scene simulator's fidelities (``[run].fidelity``, ``tdicam run --fidelity``): every
#: effect exactly, the fast engine, or fast where it is exact enough (docs: fidelity).
FIDELITIES = ("exact", "fast", "auto")


@dataclass(frozen=True)
class Run:
    """``[run]``: how much to simulate and how exactly; ``figure_crop`` the top-left
    ``(column, line)`` of the crop ``tdicam run``'s crop and profile figures show (None:
    centred)."""

    lines: int
    seed: int
    fidelity: str
    tolerance: float
    rtl: RtlRun | None
    figure_crop: tuple | None = None


