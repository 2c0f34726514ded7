"""The scene-format reference page (``docs/scene-format.md``), generated from the schema.

The schema is the validating reader :func:`tdicam.scene.loader.scene_from_dict`; there is no second
copy of it. :func:`schema` runs that reader on a set of probe scenes (every section, every
target kind, every pipeline block, the NAND flash store, ``[run.rtl]``, two ADC widths) with
its key readers instrumented, and records for every key the type, default and range the
reader applies, and the keys each section accepts. What the reader cannot say — the meaning
and the unit of a key, and the rule behind a default or bound computed from other keys
(``[sensor].conversion_gain_e_per_dn`` defaults to ``full_well_e / 2**bits``) — is in
:data:`KEYS`, next to nothing else. :func:`render` fails when the two disagree: a key the
reader accepts without an entry in :data:`KEYS`, an entry for a key it does not accept, or a
default or range that changes between probes without a written rule.

Regenerate the page with ``python -m tdicam.scene.docs docs/scene-format.md``;
``tests/test_scenedoc.py`` checks it is up to date.
"""

from __future__ import annotations

import contextlib
import sys
from dataclasses import dataclass, field
from pathlib import Path

from tdicam import blocks
from tdicam.beats import PPC_CHOICES
from tdicam.blocks import KeyDoc
from tdicam.model.physics import camera
from tdicam.scene import loader
from tdicam.model.physics import targets as _targets

__all__ = ["KEYS", "SECTIONS", "KeyDoc", "KeyInfo", "schema", "render", "main"]


@dataclass
class KeyInfo:
    """What the reader applies to one key, merged over the probe scenes."""

    kind: str | None = None
    defaults: set = field(default_factory=set)
    raw_defaults: set = field(default_factory=set)
    ranges: set = field(default_factory=set)
    choices: tuple | None = None
    sweep: bool = False


_PAPERS = ("Qu et al. 2010: Qu, Zhang, Jin, \"Improving the function of area-array CMOS image "
           "sensors with a digital-domain TDI algorithm\", Optics and Precision Engineering "
           "18(8), 2010. Tao et al. 2012: Tao, Jin, Qu, He, Yang, \"Design and analysis of a "
           "digital-domain TDI CMOS camera for high-resolution space imaging\", 2012. Ning et "
           "al. 2019: Ning, Liu, Zhao, Guo, \"Design of a large-array high-frame-rate CMOS "
           "imaging electronics system\", Optics and Precision Engineering 27(5), 2019.")

#: Sections in page order, with what each is for.
SECTIONS = {
    "orbit": "A satellite on a circular orbit looking straight down. Exactly one of [orbit] "
             "and [turntable]. Line period T1 = gsd / v_g with v_g the ground-track speed "
             "(Qu et al. 2010, eqs 4-5).",
    "turntable": "A laboratory turntable rig: the sensor looks at a target on a drum turning "
                 "at a constant rate. Exactly one of [orbit] and [turntable]. Line period "
                 "T_line = a / (omega l), a the pixel pitch (Tao et al. 2012, eq 5).",
    "target": "What the camera looks at and how bright it is. Keys of one kind are refused "
              "with another kind.",
    "sensor": "The CMOS area sensor. Impairments default to zero so that a scene simulates "
              "only what it asks for. Row timing is optional: pixel_clock_mhz (with "
              "row_blanking_us) gives T_row = t_rb + columns / f_s, or max_frame_rate_hz "
              "gives T_row = 1 / (rows F); not both. With a row time the window limit M0 "
              "(rows read in one line period, Tao et al. 2012 eq 13) bounds [tdi].stages.",
    "sensor.lvds": "Optional: the sensor's serial LVDS lanes (the front end of Ning et al. "
                   "2019's camera; defaults the GMAX0504's: 40 lanes per gain channel, 12-bit "
                   "words, 300 Mbit/s). Without it the lanes are ideal and no link is "
                   "simulated. Lane g L + k carries columns k, k+L, ... of gain channel g "
                   "(high-gain lanes first); with [sensor].bits = word_bits the all-ones "
                   "code is the sync word and full scale is sent as one less. A lane whose "
                   "eye is too narrow to train (no run of 9 taps) has its columns invalid (0, "
                   "reported in the run's notes).",
    "optics": "The lens (optional section).",
    "tdi": "Time delay integration. Each stage count must not exceed [sensor].rows nor M0 "
           "when the row timing gives one; digital TDI takes at most 128 stages and, unless "
           "an hdr merge feeds it, 8..14-bit pixels ([sensor].bits): the golden "
           "accumulator's limits, the same for every fidelity.",
    "motion": "Motion errors of the platform.",
    "pipeline": "The processing chain of the camera electronics (Ning et al. 2019): cds, nuc "
                "and hdr act on single exposures, so they come before tdi and in that order; "
                "median3 may come before or after tdi. Options of a block only when it is "
                "listed in blocks.",
    "ddr": "Optional: the DDR memory beside the FPGA that a pipeline may spill TDI's partial "
           "sums to. A pipeline whose partial sums must spill and no [ddr] section is an "
           "error.",
    "camera": "Optional: the whole camera's rate budget that tdicam plan prints (lanes, "
              "processing clock, DDR traffic of the coefficients and reset frames, NAND "
              "load, output links; Ning et al. 2019), defaults the paper's camera. The "
              "golden chain and the gateware do not read it.",
    "run": "How much to simulate and how exactly.",
    "run.rtl": "Optional: co-simulate the scene's blocks cycle-accurately on a crop of the "
               "output (generated Verilog on Icarus or Verilator) and compare every pixel. "
               "Needs [tdi].domain = \"digital\" (charge-domain TDI has no gateware chain).",
}

_FRAC = "fraction"


def _camera_unit(key):
    """The unit of a ``[camera]`` key, read off its name's suffix."""
    for suffix, unit in (("_mhz", "MHz"), ("_hz", "Hz"), ("_mts", "MT/s"), ("_bits", "bit")):
        if key.endswith(suffix):
            return unit
    return {"ddr_interfaces": "interfaces", "nand_parts": "parts", "links": "links"}.get(key, "")
#: Unit and meaning of every key, by section (see :class:`KeyDoc`); a block's
#: ``[pipeline.<block>]`` keys are its registry entry's (:class:`tdicam.blocks.Options`).
KEYS = {
    "orbit": {
        "altitude_km": KeyDoc("km", "orbit altitude above a spherical Earth (R = 6378.137 km)"),
        "gsd_m": KeyDoc("m", "ground sample distance: the ground size of one pixel"),
    },
    "turntable": {
        "angular_speed_rad_s": KeyDoc("rad/s", "angular speed of the turntable"),
        "distance_m": KeyDoc("m", "distance from the sensor to the rotation axis"),
    },
    "target": {
        "kind": KeyDoc("", "the target: a picture (image), bar chart (bars), slanted edge "
                           "(edge), Siemens star (siemens) or a uniform field (flat)"),
        "signal_e": KeyDoc("e-", "light level: the electrons one pixel collects in one "
                                 "exposure (one line period, one stage) from the brightest "
                                 "part of the target (image value 1.0, bright bar, bright "
                                 "side of the edge; a flat target is uniform at this level)"),
        "image": KeyDoc("", "kind = \"image\": a picture bundled with scikit-image: "
                            + ", ".join(loader.BUNDLED_IMAGES)
                            + "; exactly one of image and path",
                        type="string", default="-", range="a bundled name"),
        "path": KeyDoc("", "kind = \"image\": a PNG or TIFF file, relative to the scene "
                           "file; exactly one of image and path. Read when the scene is: "
                           "one picture, channels last: grey, grey + alpha, RGB or RGBA "
                           "(palette PNGs expanded); RGB to grey with the Rec. 601 weights "
                           "0.299 R + 0.587 G + 0.114 B; alpha must be opaque everywhere "
                           "(then dropped); integer codes over their type's full scale "
                           "(255, 65535), floats as they are if at most 1.0, else over "
                           "their largest value; negative, NaN and complex values refused",
                       type="string", default="-",
                       range=".png, .tif, .tiff; >= "
                             f"{_targets.MIN_IMAGE_SIDE} x {_targets.MIN_IMAGE_SIDE} px"),
        "contrast": KeyDoc(_FRAC, "bars, edge, siemens: Michelson contrast; the dark level "
                                  "is signal_e (1 - c) / (1 + c)"),
        "period_px": KeyDoc("output px", "bars: bar period"),
        "direction": KeyDoc("", "bars: the axis the bar pattern varies along"),
        "profile": KeyDoc("", "bars: square bars, or a sine grating (one spatial "
                              "frequency, to measure the MTF at exactly 1/period_px)"),
        "angle_deg": KeyDoc("deg", "edge: slant of the edge from the cross-track axis"),
        "spokes": KeyDoc("", "siemens: number of spoke pairs"),
    },
    "sensor": {
        "columns": KeyDoc("px", "pixels per row (cross track)"),
        "rows": KeyDoc("px", "rows of the area sensor (the TDI window is at most this)"),
        "pitch_um": KeyDoc("um", "pixel pitch"),
        "fill_factor": KeyDoc(_FRAC, "area fill factor; the aperture MTF uses "
                                     "q/p = sqrt(fill_factor) (square active area)"),
        "bits": KeyDoc("bit", "ADC resolution"),
        "full_well_e": KeyDoc("e-", "full-well capacity"),
        "conversion_gain_e_per_dn": KeyDoc(
            "e-/DN", "electrons per ADC code at channel gain 1 (a channel of gain g has "
                     "conversion / g e-/DN)", default="full_well_e / 2**bits"),
        "read_noise_e": KeyDoc("e- RMS", "temporal read noise of one exposure"),
        "dark_current_e_per_s": KeyDoc("e-/s", "dark current"),
        "prnu": KeyDoc(_FRAC, "photo-response non-uniformity, RMS (0.015 = 1.5 %)"),
        "dsnu_e": KeyDoc("e- RMS", "dark-signal non-uniformity"),
        "shutter": KeyDoc("", "rolling (rows start one row time apart: skew) or global "
                              "(assumed pipelined)"),
        "row_blanking_us": KeyDoc("us", "row blanking time t_rb (3.5 us: Tao et al. 2012's "
                                        "typical value); used with pixel_clock_mhz"),
        "pixel_clock_mhz": KeyDoc("MHz", "pixels per second over all output channels; "
                                         "gives the row time with row_blanking_us"),
        "max_frame_rate_hz": KeyDoc("Hz", "the datasheet full-frame rate; gives the row time "
                                          "instead of pixel_clock_mhz"),
        "gains": KeyDoc("", "channel gains: one, or two as [high, low] with high > low "
                            "(Ning et al. 2019: [4.9, 0.8])",
                        type="list of 1 or 2 numbers", range="each in (0, 1e6]"),
        "black_level_dn": KeyDoc("DN", "ADC offset (pedestal) added to every sample, so that "
                                       "read noise around a dark level is not clipped at "
                                       "code 0", range="[0, 2**bits)"),
    },
    "optics": {
        "psf_sigma_px": KeyDoc("px", "standard deviation of a Gaussian optics PSF (0: a "
                                     "perfect lens, the optics effect is skipped)"),
    },
    "tdi": {
        "stages": KeyDoc("", "TDI stages m: the exposures added per output line; a list "
                             "sweeps them (one run each)",
                         range=">= 1, <= [sensor].rows and M0; digital: <= 128"),
        "domain": KeyDoc("", "digital (m reads added in the FPGA, Qu et al. 2010) or charge "
                             "(charge summed before one read, as an interline CCD does)"),
        "direction": KeyDoc("", "scan direction: which end of the window a ground line "
                                "enters"),
        "output": KeyDoc("", "full: bits + ceil(log2 m) output bits, no overflow; saturate: "
                             "clip at output_bits"),
        "output_bits": KeyDoc("bit", "output width with output = \"saturate\"",
                              default="[sensor].bits"),
    },
    "motion": {
        "dv_over_v": KeyDoc(_FRAC, "relative velocity mismatch dV/V between the image and "
                                   "the TDI line clock; a list sweeps it"),
        "drift_deg": KeyDoc("deg", "drift (crab) angle between the flight direction and the "
                                   "sensor columns"),
    },
    "pipeline": {
        "blocks": KeyDoc("", "the ordered processing chain, from cds, nuc, hdr, tdi, median3; "
                             "tdi exactly once, no repeats",
                         type="list of strings", range="order rules above"),
    },
    "ddr": {
        "interface": KeyDoc("", "the DDR controller's user interface"),
        "base": KeyDoc("byte", "byte address of the first buffer; the buffer (cds_ddr's "
                               "reset frame) must fit between it and the memory's end",
                       range="multiple of 8, 0..2**28 - 8"),
        "refresh_period": KeyDoc("cycles", "co-simulation: the DDR controller model's cycles "
                                           "between refresh starts"),
        "refresh_cycles": KeyDoc("cycles", "co-simulation: cycles of each refresh (the "
                                           "controller not ready)",
                                 range="0..refresh_period - 1"),
        "lat_lo": KeyDoc("cycles", "co-simulation: the model's shortest read latency"),
        "lat_hi": KeyDoc("cycles", "co-simulation: the model's longest read latency; "
                                   "refresh_cycles + lat_hi is the longest stall, which also "
                                   "sizes the sensor front end's crossing FIFO (at most 256 "
                                   "entries: a scene with [sensor.lvds] takes only the stalls "
                                   "that fit it; the plan and the run say which)",
                         range="lat_lo..1000"),
        "drop": KeyDoc("/256", "co-simulation: each ready of the model dropped with "
                               "probability drop/256 a cycle"),
    },
    "camera": {k: KeyDoc(_camera_unit(k), doc, **(
        {"default": "[sensor].max_frame_rate_hz" if k == "frame_rate_hz" else
         "frame_rate_hz"} if d is None else {}))
        for k, (d, _lo, _hi, doc) in camera.KEYS.items()},
    "run": {
        "lines": KeyDoc("lines", "output lines to simulate"),
        "seed": KeyDoc("", "seed of every random number of the run (noise, faults)"),
        "fidelity": KeyDoc("", "exact: quantize every exposure as the camera does; fast: "
                               "one aggregate of the m exposures with the rounding moments "
                               "added statistically; auto: fast where its stated error bound "
                               "is below tolerance, else exact"),
        "tolerance": KeyDoc(_FRAC, "largest relative RMS error auto accepts from fast"),
        "figure_crop": KeyDoc("px", "top-left [column, line] of the 64 x 64 crop that "
                                    "crop.png and profile.png show (moved in to fit)",
                              type="[integer, integer]", default="centred",
                              range="inside the output"),
    },
    "sensor.lvds": {
        "lanes_per_gain": KeyDoc("lanes", "lanes per gain channel; must divide "
                                          "[sensor].columns; the front end takes at most 128 "
                                          "lanes in all the gains it merges (64 a gain with "
                                          "hdr)"),
        "word_bits": KeyDoc("bits", "bits per word (>= [sensor].bits)", range="10, 12"),
        "bit_rate_mbps": KeyDoc("Mbit/s", "bit rate of each lane"),
        "mapping": KeyDoc("", "lane-to-column mapping: lane k carries columns k, k+L, ..."),
        "train_word": KeyDoc("", "training word the sensor sends before the first frame",
                             default="0xB92 (12 bits), 0x2E4 (10 bits)",
                             range="0..2**word_bits-2, its rotations all different"),
        "tap_ps": KeyDoc("ps", "IDELAY tap (paper 5 ns / 32; a 7-series IDELAYE2 at 200 MHz "
                               "78.125 ps)"),
        "eye_centre_taps": KeyDoc("taps", "delay tap at the centre of each lane's eye",
                                  type="number or list (one per lane)", default="16",
                                  range="[0, 31]"),
        "eye_width_taps": KeyDoc("taps", "width of each lane's eye; given: the lanes' "
                                         "training is simulated",
                                 type="number or list (one per lane)",
                                 default="the whole bit (ideal)", range="[0, UI / tap_ps]"),
        "jitter_ps": KeyDoc("ps", "random capture band inside each eye edge; given: the "
                                  "lanes' training is simulated", range="[0, UI]"),
        "eye_status": KeyDoc("", "the receiver publishes its training (tap pass masks, "
                                 "chosen tap and slip, eye width) and checks every bit with "
                                 "walking-1/0 patterns after lock; tdicam run reports them "
                                 "(eyes.png); adds ports to the pipeline top"),
        "drift_taps": KeyDoc("taps", "slow drift of each eye's centre over drift_frames "
                                     "(+: to higher taps), as temperature moves it",
                             type="number or list (one per lane)", default="0",
                             range="[-31, 31]"),
        "drift_frames": KeyDoc("frames", "frames (as the sensor sends them, from its first) "
                                         "over which the eyes drift by drift_taps"),
        "tracking": KeyDoc("", "the receiver follows each locked lane's eye with a monitor "
                               "sampler 4 taps either side and reports every correction "
                               "(generic PHY); adds ports to the pipeline top"),
    },
    "run.rtl": {
        "crop": KeyDoc("px", "[x0, y0, width, height] of the output to co-simulate",
                       type="list of 4 integers", default="whole frame",
                       range="inside columns x lines"),
        "simulator": KeyDoc("", "the HDL simulator"),
        "pixels_per_clock": KeyDoc("px/clock", "pixels per clock of the whole-chain top's "
                                               "input and of every block up to TDI (a block "
                                               "after TDI's m stages at ppc / m, at least 1, "
                                               "behind a width converter; also the default "
                                               "--ppc of tdicam verilog|synth|export "
                                               "pipeline)",
                                   range=f"{', '.join(map(str, PPC_CHOICES))}; dividing the crop width"),
        "lane_dies": KeyDoc("", "[lane, frame]: a sensor lane dying in the middle of that "
                                "frame of the co-simulation (frames as the sensor sends "
                                "them, reset frames included); the controller retrains "
                                "after the next two frames",
                            type="list of 2 integers", default="none",
                            range="lane 0..lanes - 1; with reset frames a signal frame "
                                  "(odd); needs [sensor.lvds]"),
    },
}

_TYPES = {"number": "number", "integer": "integer", "choice": "string", "boolean": "boolean",
          "string": "string"}


def _with_blocks(table, value):
    """``table`` with each block's ``pipeline.<block>`` entry (``value(options)``) right after
    ``pipeline``, in the blocks' scene order."""
    out = {}
    for section, v in table.items():
        out[section] = v
        if section == "pipeline":
            for b in blocks.scene_blocks():
                if b.pipeline.options is not None:
                    out[f"pipeline.{b.name}"] = value(b.pipeline.options)
    return out


SECTIONS = _with_blocks(SECTIONS, lambda o: o.doc)
KEYS = _with_blocks(KEYS, lambda o: dict(o.keys))


def _probes():
    """Scenes that together reach every key reader of :func:`tdicam.scene.loader.scene_from_dict`."""
    orbit = {"orbit": {"altitude_km": 600.0, "gsd_m": 1.0}}
    turn = {"turntable": {"angular_speed_rad_s": 0.1, "distance_m": 1.0}}
    out = []
    for bits, extra in ((12, {}), (14, {"full_well_e": 30000.0, "pixel_clock_mhz": 400.0})):
        # two gains where the hdr merge's output still fits TDI's pixels (<= 14 bits)
        sensor = {"bits": bits, "gains": [2.0, 1.0] if bits <= 12 else [1.0], **extra}
        listed = blocks.scene_blocks()
        full = {"blocks": [b.name for b in listed],
                **{b.name: dict(b.pipeline.options.probe) for b in listed
                   if b.pipeline.options is not None}}
        out += [
            {**orbit, "target": {"kind": "flat"}, "sensor": sensor, "pipeline": full,
             "optics": {}, "tdi": {"stages": [4]}, "motion": {"dv_over_v": [0.0]},
             "run": {"rtl": {}}},
            {**turn, "target": {"kind": "bars"}, "sensor": {"bits": bits,
                                                            "max_frame_rate_hz": 100.0}},
            {**orbit, "target": {"kind": "edge"}, "sensor": {"bits": bits},
             "pipeline": {"blocks": ["tdi", "median3"], "tdi": {"memory": "ddr"}},
             "ddr": {"interface": "mig", "base": 0, "refresh_period": 780, "refresh_cycles": 44,
                     "lat_lo": 20, "lat_hi": 60, "drop": 16},
             "run": {"rtl": {"crop": [0, 0, 4, 4]}}},
            {**orbit, "target": {"kind": "siemens"}, "sensor": {
                "bits": bits, "columns": 80, **({"lvds": {
                    "lanes_per_gain": 40, "word_bits": 12, "bit_rate_mbps": 300.0,
                    "mapping": "interleaved", "train_word": 0xB92, "tap_ps": 156.25,
                    "eye_centre_taps": 16.0, "eye_width_taps": 12.0, "jitter_ps": 0.0}}
                    if bits <= 12 else {})},
             "pipeline": {"blocks": ["cds", "nuc", "tdi"]}},
            {**orbit, "target": {"kind": "image", "image": "camera"}, "sensor": {"bits": bits},
             "camera": {k: d for k, (d, *_r) in camera.KEYS.items() if d is not None}
             | {"frame_rate_hz": 25.0, "output_frame_rate_hz": 5.0}},
        ]
    return out


def schema():
    """``({section: allowed keys}, {(section, key): KeyInfo})``, read off the validating
    reader by running it on the probe scenes (see the module docstring)."""
    S = loader._Section
    allowed: dict[str, tuple] = {}
    info: dict[tuple, KeyInfo] = {}
    req = loader._REQUIRED

    def rec(sec, key):
        return info.setdefault((sec.name, key), KeyInfo())

    def rng(lo, hi, lo_open=False, hi_open=False):
        return (lo, hi, lo_open, hi_open)

    orig = {n: getattr(S, n) for n in ("check_keys", "number", "integer", "choice", "boolean",
                                        "string", "sweep", "raw")}

    def check_keys(self, keys):
        allowed.setdefault(self.name, tuple(keys))
        return orig["check_keys"](self, keys)

    # the wrappers forward everything they are given, so a new option of a reader does not
    # break the probe; they only read the options they document
    def typed(kind):
        def wrapper(self, key, default=req, **kw):
            r = rec(self, key)
            r.kind = kind
            if kw.get("value", req) is req:
                r.defaults.add(default if default is not req else "required")
            bound = loader.BOUNDS.get(f"{self.name}.{key}")     # replaces lo/hi (the reader)
            r.ranges.add(rng(*bound) if bound else
                         rng(kw.get("lo"), kw.get("hi"), kw.get("lo_open", False),
                             kw.get("hi_open", False)))
            return orig[kind](self, key, default, **kw)
        return wrapper

    def choice(self, key, default, choices, *args, **kw):
        r = rec(self, key)
        r.kind, r.choices = "choice", tuple(choices)
        r.defaults.add(default)
        return orig["choice"](self, key, default, choices, *args, **kw)

    def boolean(self, key, default, *args, **kw):
        r = rec(self, key)
        r.kind = "boolean"
        r.defaults.add(default)
        return orig["boolean"](self, key, default, *args, **kw)

    def string(self, key, default=req, *args, **kw):
        r = rec(self, key)
        r.kind = "string"
        r.defaults.add(default if default is not req else "required")
        return orig["string"](self, key, default, *args, **kw)

    def raw(self, key, default, *args, **kw):
        d = "required" if default is req else default
        rec(self, key).raw_defaults.add(tuple(d) if isinstance(d, list) else d)
        return orig["raw"](self, key, default, *args, **kw)

    def sweep(self, key, default, item, *args, **kw):
        r = rec(self, key)
        r.sweep = True
        r.defaults.add(default)
        return orig["sweep"](self, key, default, item, *args, **kw)

    patches = {"check_keys": check_keys, "number": typed("number"),
               "integer": typed("integer"), "choice": choice, "boolean": boolean,
               "string": string, "sweep": sweep, "raw": raw}
    with contextlib.ExitStack() as stack:
        for name, fn in patches.items():
            setattr(S, name, fn)
            stack.callback(setattr, S, name, orig[name])
        for data in _probes():
            loader.scene_from_dict(data)
    return allowed, info


def _num(v):
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e15:
        return str(int(v))
    return f"{v:g}" if isinstance(v, float) else str(v)


def _range_text(r):
    lo, hi, lo_open, hi_open = r
    if lo is None and hi is None:
        return "any"
    if hi is None:
        return f"{'>' if lo_open else '>='} {_num(lo)}"
    if lo is None:
        return f"{'<' if hi_open else '<='} {_num(hi)}"
    if not lo_open and not hi_open and isinstance(lo, int) and isinstance(hi, int):
        return f"{lo}..{hi}"
    return f"{'(' if lo_open else '['}{_num(lo)}, {_num(hi)}{')' if hi_open else ']'}"


def _default_text(d):
    if d == "required":
        return "**required**"
    if d is None:
        return "not set"
    if isinstance(d, bool):
        return "true" if d else "false"
    if isinstance(d, str):
        return f"\"{d}\""
    if isinstance(d, (list, tuple)):
        return "[" + ", ".join(_default_text(x) for x in d) + "]"
    return _num(d)


def _one(what, values, written, where):
    if written is not None:
        return written
    if len(values) != 1:
        raise ValueError(f"{where}: the {what} depends on other keys ({sorted(map(str, values))});"
                         f" write its rule in tdicam.scene.docs.KEYS")
    return next(iter(values))


def _row(section, key, doc: KeyDoc, r: KeyInfo | None):
    where = f"[{section}].{key}"
    if doc.type is not None:
        kind = doc.type
    elif r is None or r.kind is None:
        raise ValueError(f"{where}: its reader records no type; write it in "
                         f"tdicam.scene.docs.KEYS")
    else:
        kind = _TYPES[r.kind]
    if r is not None and r.sweep:
        kind = f"{kind} or list of them"
    if doc.default is not None:
        default = doc.default
    elif r is not None and (r.defaults or r.raw_defaults):
        default = _default_text(_one("default", r.defaults or r.raw_defaults, None, where))
    else:
        raise ValueError(f"{where}: no default recorded; write it in tdicam.scene.docs.KEYS")
    if doc.range is not None:
        rng = doc.range
    elif r is not None and r.choices:
        rng = ", ".join(f"\"{c}\"" for c in r.choices)
    elif r is not None and r.kind == "boolean":
        rng = "true, false"
    elif r is not None and r.ranges:
        rng = _range_text(_one("range", r.ranges, None, where))
    else:
        raise ValueError(f"{where}: no range recorded; write it in tdicam.scene.docs.KEYS")
    return f"| `{key}` | {kind} | {doc.unit or '-'} | {default} | {rng} | {doc.meaning} |"


def render():
    """The Markdown text of ``docs/scene-format.md``.

    Raises
    ------
    ValueError
        The reader and :data:`KEYS` / :data:`SECTIONS` disagree (names the key).
    """
    allowed, info = schema()
    subsections = {s for s in allowed if "." in s}
    if set(allowed) != set(SECTIONS):
        raise ValueError(f"sections of the reader {sorted(allowed)} != documented "
                         f"{sorted(SECTIONS)}")
    md = ["# Scene file format", "",
          "<!-- generated by `python -m tdicam.scene.docs docs/scene-format.md` from the scene "
          "reader (tdicam/scene/loader.py); tests/test_scenedoc.py checks it is up to date -->", "",
          "A scene is a TOML file: the platform motion, the target and its light level, the "
          "sensor, TDI, motion errors, the processing pipeline and how to run the "
          "simulation. `tdicam run SCENE` simulates it; `tdicam plan --scene SCENE` sizes "
          "it; `tdicam sweep` varies any of its keys (written `\"section.key\"`). "
          "Every key is optional unless marked required. Unknown sections and keys are "
          "errors (with a did-you-mean hint), and a bad value gets a one-line error naming "
          "the key, e.g. `[sensor].read_noise_e: must be >= 0, got -1`. Examples: the "
          "`scenes/` folder.", "",
          "Ranges: `a..b` integers from a to b; `[a, b)` / `(a, b]` numbers with the bound "
          "on the round-bracket side excluded. Units: e- electrons, DN ADC codes "
          "(digital numbers), px pixels, output px pixels of the TDI output image.", ""]
    for section, text in SECTIONS.items():
        keys = [k for k in allowed[section] if f"{section}.{k}" not in subsections]
        docs = KEYS.get(section, {})
        if set(keys) != set(docs):
            missing = sorted(set(keys) - set(docs))
            extra = sorted(set(docs) - set(keys))
            raise ValueError(f"[{section}]: keys without documentation {missing}, documented "
                             f"keys the reader refuses {extra}: update tdicam.scene.docs.KEYS")
        md += [f"## [{section}]", "", text, ""]
        if keys:
            md += ["| key | type | unit | default | allowed | meaning |",
                   "|---|---|---|---|---|---|"]
            md += [_row(section, k, doc, info.get((section, k))) for k, doc in docs.items()]
            md.append("")
    md += ["## Papers", "", _PAPERS, ""]
    return "\n".join(md)


def main(argv=None):
    """``python -m tdicam.scene.docs [FILE]``: write the page to FILE (default: stdout)."""
    argv = sys.argv[1:] if argv is None else argv
    text = render()
    if argv:
        Path(argv[0]).parent.mkdir(parents=True, exist_ok=True)
        Path(argv[0]).write_text(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
