"""The scene's sections: one validating reader per TOML table, each beside the unit and
meaning of its keys (``<SECTION>_KEYS``, :class:`tdicam.blocks.KeyDoc`; :data:`KEYS` all of
them). A reader states every key's type, default and range as it reads it
(:class:`tdicam.scene.reading.Section`); the reference page (:mod:`tdicam.scene.docs`) reads
those off the reader and the meanings from here. :mod:`tdicam.scene.loader` calls the readers
and makes the cross-section checks.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tdicam import blocks
from tdicam.beats import PPC_CHOICES
from tdicam.errors import TdicamError
from tdicam.hdl.lvds_phy import PHYS, TRACKING_WORD_BITS
from tdicam.model import lvds_front
from tdicam.model.physics import camera
from tdicam.model.physics.camera import Camera
from tdicam.model.lvds import N_TAPS, PAPER_TAP_PS, default_train_word, rotations
from tdicam.model.physics import targets as _targets
from tdicam.scene.schema import (BLOCKS, BUNDLED_IMAGES, DDR_INTERFACES, FIDELITIES, TARGET_KINDS,
                                 Ddr, Lvds, Motion, Optics, Orbit, Pipeline, RtlRun, Run, Sensor,
                                 TargetSpec, Tdi, Turntable)

from tdicam.blocks import KeyDoc
from tdicam.scene.reading import Section, hint, show

__all__ = ["KEYS", "ORBIT_KEYS", "TURNTABLE_KEYS", "TARGET_KEYS", "SENSOR_KEYS",
           "SENSOR_LVDS_KEYS", "OPTICS_KEYS", "TDI_KEYS", "MOTION_KEYS", "PIPELINE_KEYS",
           "CAMERA_KEYS", "DDR_KEYS", "RUN_KEYS", "RUN_RTL_KEYS", "read_orbit", "read_turntable",
           "read_target", "read_sensor", "read_lvds", "read_optics", "read_tdi", "read_motion",
           "read_pipeline", "read_camera", "read_ddr", "read_run"]

_FRAC = "fraction"


def _camera_unit(key):
    """The unit of a ``[camera]`` key, read off its name's suffix."""
    for suffix, unit in (("_mhz", "MHz"), ("_hz", "Hz"), ("_mts", "MT/s"), ("_bits", "bit")):
        if key.endswith(suffix):
            return unit
    return {"ddr_interfaces": "interfaces", "nand_parts": "parts", "links": "links"}.get(key, "")
#: Unit and meaning of every key, by section (see :class:`KeyDoc`); a block's
#: ``[pipeline.<block>]`` keys are its registry entry's (:class:`tdicam.blocks.Options`).


_IMAGE_SUFFIXES = (".png", ".tif", ".tiff")
_KIND_KEYS = {
    "image": ("image", "path"),
    "bars": ("period_px", "contrast", "direction", "profile"),
    "edge": ("contrast", "angle_deg"),
    "siemens": ("contrast", "spokes"),
    "flat": (),
}




#: ``[orbit]``: unit and meaning of every key (:class:`tdicam.blocks.KeyDoc`).
ORBIT_KEYS = {
    "altitude_km": KeyDoc("km", "orbit altitude above a spherical Earth (R = 6378.137 km)"),
    "gsd_m": KeyDoc("m", "ground sample distance: the ground size of one pixel"),
}


def read_orbit(sec: Section) -> Orbit:
    sec.check_keys(("altitude_km", "gsd_m"))
    return Orbit(altitude_km=sec.number("altitude_km"), gsd_m=sec.number("gsd_m"))


#: ``[turntable]``: unit and meaning of every key (:class:`tdicam.blocks.KeyDoc`).
TURNTABLE_KEYS = {
    "angular_speed_rad_s": KeyDoc("rad/s", "angular speed of the turntable"),
    "distance_m": KeyDoc("m", "distance from the sensor to the rotation axis"),
}


def read_turntable(sec: Section) -> Turntable:
    sec.check_keys(("angular_speed_rad_s", "distance_m"))
    return Turntable(angular_speed_rad_s=sec.number("angular_speed_rad_s"),
                     distance_m=sec.number("distance_m"))


#: ``[target]``: unit and meaning of every key (:class:`tdicam.blocks.KeyDoc`).
TARGET_KEYS = {
    "kind": KeyDoc("", "the target: a picture (image), bar chart (bars), slanted edge "
                       "(edge), Siemens star (siemens) or a uniform field (flat)"),
    "signal_e": KeyDoc("e-", "light level: the electrons one pixel collects in one "
                             "exposure (one line period, one stage) from the brightest "
                             "part of the target (image value 1.0, bright bar, bright "
                             "side of the edge; a flat target is uniform at this level)"),
    "image": KeyDoc("", "kind = \"image\": a picture bundled with scikit-image: "
                        + ", ".join(BUNDLED_IMAGES)
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
}


def read_target(sec: Section, base_dir: Path) -> TargetSpec:
    kind = sec.choice("kind", "flat", TARGET_KINDS)
    common = ("kind", "signal_e")
    all_keys = set(common).union(*_KIND_KEYS.values())
    for key in sec.data:
        if key in all_keys and key not in common and key not in _KIND_KEYS[kind]:
            owners = [k for k, keys in _KIND_KEYS.items() if key in keys]
            sec.fail(key, f"not used with kind = {kind!r} (it belongs to kind "
                          + " or ".join(repr(o) for o in owners) + ")")
    sec.check_keys(sorted(all_keys))
    signal = sec.number("signal_e", 1000.0)
    fields: dict[str, Any] = {}
    if kind == "image":
        has_image, has_path = sec.has("image"), sec.has("path")
        if has_image == has_path:
            which = "both" if has_image else "neither"
            sec.fail("path", f"kind = 'image' needs exactly one of {sec.label('image')} (a "
                             f"bundled picture) or {sec.label('path')} (a PNG/TIFF file), "
                             f"got {which}")
        if has_image:
            name = sec.string("image")
            if name not in BUNDLED_IMAGES:
                sec.fail("image", f"unknown bundled image {name!r}"
                                  + hint(name, BUNDLED_IMAGES))
            fields["image"] = name
        else:
            raw = sec.string("path")
            path = Path(raw).expanduser()
            if not path.is_absolute():
                path = base_dir / path
            if path.suffix.lower() not in _IMAGE_SUFFIXES:
                sec.fail("path", f"must be a PNG or TIFF file (.png, .tif, .tiff), got {raw!r}")
            if path.is_dir():
                sec.fail("path", f"{str(path)!r} is a folder, not an image file")
            if path.exists() and not path.is_file():
                sec.fail("path", f"{str(path)!r} is not a regular file (a device or a pipe), "
                                 f"not an image file")
            if not path.is_file():
                sec.fail("path", f"file not found: {str(path)!r}")
            fields["path"] = path.resolve()
            _targets.load_image(fields["path"])     # size, channels, values: refused here
    if kind in ("bars", "edge", "siemens"):
        fields["contrast"] = sec.number("contrast", 1.0, lo=0.0, hi=1.0, lo_open=True)
    if kind == "bars":
        fields["period_px"] = sec.number("period_px", 8.0, lo=2.0)
        fields["direction"] = sec.choice("direction", "along_track",
                                         ("along_track", "cross_track"))
        fields["profile"] = sec.choice("profile", "square", ("square", "sine"))
    elif kind == "edge":
        fields["angle_deg"] = sec.number("angle_deg", 5.0, lo=-45.0, hi=45.0)
    elif kind == "siemens":
        fields["spokes"] = sec.integer("spokes", 36, lo=4, hi=720)
    return TargetSpec(kind=kind, signal_e=signal, **fields)


#: ``[sensor]``: unit and meaning of every key (:class:`tdicam.blocks.KeyDoc`).
SENSOR_KEYS = {
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
}


_SENSOR_ALLOWED = ("columns", "rows", "pitch_um", "fill_factor", "bits", "full_well_e",
                "conversion_gain_e_per_dn", "read_noise_e", "dark_current_e_per_s", "prnu",
                "dsnu_e", "shutter", "row_blanking_us", "pixel_clock_mhz",
                "max_frame_rate_hz", "gains", "black_level_dn", "lvds")


def read_sensor(sec: Section) -> Sensor:
    sec.check_keys(_SENSOR_ALLOWED)
    bits = sec.integer("bits", 12)
    full_well = sec.number("full_well_e", 20000.0)
    conv = sec.number("conversion_gain_e_per_dn", None)
    if sec.has("pixel_clock_mhz") and sec.has("max_frame_rate_hz"):
        sec.fail("max_frame_rate_hz", f"give either {sec.label('pixel_clock_mhz')} (with "
                                      f"{sec.label('row_blanking_us')}) or "
                                      f"{sec.label('max_frame_rate_hz')}, not both")
    if sec.has("row_blanking_us") and not sec.has("pixel_clock_mhz"):
        sec.fail("row_blanking_us", f"needs {sec.label('pixel_clock_mhz')} (the row time is "
                                    f"t_rb + columns / f_s; without it the blanking is unused)")
    gains_raw = sec.raw("gains", [1.0])
    if not isinstance(gains_raw, list) or not 1 <= len(gains_raw) <= 2:
        sec.fail("gains", f"must be a list of one or two gains, got {show(gains_raw)}")
    gains = tuple(sec.number("gains", value=g, lo=0.0, lo_open=True, hi=1e6,  # 1e308: inf
                             what=f"(entry {i} of the list)")
                  for i, g in enumerate(gains_raw))
    if len(gains) == 2 and not gains[0] > gains[1]:
        sec.fail("gains", f"two gains must be [high, low] with high > low, got {show(gains_raw)}")
    columns = sec.integer("columns", 1280)
    lvds = None
    if sec.has("lvds"):
        lvds = read_lvds(Section(f"{sec.name}.lvds", sec.data["lvds"], sec.labels), columns, bits,
                     len(gains), sec.integer("rows", 1024))
    return Sensor(
        lvds=lvds,
        columns=columns,
        rows=sec.integer("rows", 1024),
        pitch_um=sec.number("pitch_um", 5.5),
        fill_factor=sec.number("fill_factor", 1.0, lo=0.0, hi=1.0, lo_open=True),
        bits=bits,
        full_well_e=full_well,
        conversion_gain_e_per_dn=full_well / (1 << bits) if conv is None else conv,
        read_noise_e=sec.number("read_noise_e", 0.0),
        dark_current_e_per_s=sec.number("dark_current_e_per_s", 0.0),
        prnu=sec.number("prnu", 0.0, lo=0.0, hi=1.0, hi_open=True),
        dsnu_e=sec.number("dsnu_e", 0.0),
        shutter=sec.choice("shutter", "rolling", ("rolling", "global")),
        row_blanking_us=sec.number("row_blanking_us", 3.5),
        pixel_clock_mhz=sec.number("pixel_clock_mhz", None),
        max_frame_rate_hz=sec.number("max_frame_rate_hz", None),
        gains=gains,
        black_level_dn=sec.number("black_level_dn", 0.0, lo=0.0, hi=float(1 << bits),
                                  hi_open=True),
    )


#: ``[sensor.lvds]``: unit and meaning of every key (:class:`tdicam.blocks.KeyDoc`).
SENSOR_LVDS_KEYS = {
    "lanes_per_gain": KeyDoc("lanes", "lanes per gain channel (<= [sensor].columns); "
                                      "each lane sends ceil(columns / lanes) words a line, "
                                      "a lane with a column fewer a padded last slot; the "
                                      "front end takes at most 128 lanes in all the gains "
                                      "it merges (64 a gain with hdr)"),
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
    "skew_bits": KeyDoc("bits", "whole bits each lane's data arrives after the eye centre's "
                                "bit (board and sensor skew between lanes; up to a whole word: "
                                "the receiver's bitslip and word deskew take it); given: the "
                                "lanes' training is simulated",
                        type="integer or list (one per lane)", default="0",
                        range="0..word_bits"),
    "eye_status": KeyDoc("", "the receiver publishes its training (tap pass masks, "
                             "chosen tap and slip, eye width) and checks every bit with "
                             "walking-1/0 patterns after lock; tdicam run reports them "
                             "(eyes.png; with [run.rtl].phy the device PHY's too: "
                             "eyes_<phy>.png); adds ports to the pipeline top"),
    "drift_taps": KeyDoc("taps", "slow drift of each eye's centre over drift_frames "
                                 "(+: to higher taps), as temperature moves it",
                         type="number or list (one per lane)", default="0",
                         range="[-31, 31]"),
    "drift_frames": KeyDoc("frames", "frames (as the sensor sends them, from its first) "
                                     "over which the eyes drift by drift_taps"),
    "tracking": KeyDoc("", "the receiver follows each locked lane's eye with a monitor "
                           "sampler 4 taps either side and reports every correction "
                           "(the chain's generic PHY; from serial bits with [run.rtl].phy "
                           "= \"xilinx7\" and 12-bit words); adds ports to the pipeline "
                           "top"),
}


def read_lvds(sec: Section, columns: int, bits: int, gains: int, rows: int) -> Lvds:
    sec.check_keys(("lanes_per_gain", "word_bits", "bit_rate_mbps", "mapping", "train_word",
                    "tap_ps", "eye_centre_taps", "eye_width_taps", "jitter_ps", "skew_bits",
                    "eye_status",
                    "drift_taps", "drift_frames", "tracking"))
    dflt = lvds_front.GMAX0504
    lanes = sec.integer("lanes_per_gain", dflt["lanes_per_gain"], lo=1, hi=128)
    if columns < lanes:
        given = "" if sec.has("lanes_per_gain") else " (the default, the GMAX0504's; give it)"
        sec.fail("lanes_per_gain", f"{lanes}{given} is more lanes than [sensor].columns = "
                                   f"{columns} (lane k carries columns k, k+L, ...)")
    wb = sec.integer("word_bits", dflt["word_bits"])
    if wb not in (10, 12):
        sec.fail("word_bits", f"must be 10 or 12, got {wb}")
    if wb < bits:
        sec.fail("word_bits", f"{wb} is narrower than the {bits}-bit pixels ([sensor].bits)")
    if rows >= (1 << wb) - 2:           # the line header is the row index (model.lvds_front)
        sec.fail("word_bits", f"{wb}-bit words cannot number the {rows} rows of a frame "
                              f"([sensor].rows): the row header counts to {(1 << wb) - 3}")
    rate = sec.number("bit_rate_mbps", dflt["bit_rate_mbps"], lo=1.0, hi=2000.0)
    ui = 1e6 / rate
    mapping = sec.choice("mapping", "interleaved", ("interleaved",))
    tw = sec.integer("train_word", default_train_word(wb), lo=0, hi=(1 << wb) - 1)
    if len(set(rotations(tw, wb))) != wb or tw == (1 << wb) - 1:
        sec.fail("train_word", f"{tw:#x} repeats under rotation: word alignment would be "
                               f"ambiguous")
    tap = sec.number("tap_ps", PAPER_TAP_PS, lo=1.0, hi=1000.0)
    n = lanes * gains

    def per_lane(key, default, lo, hi, read=sec.number):
        v = sec.raw(key, default)
        vals = v if isinstance(v, list) else [v] * n
        if len(vals) != n:
            sec.fail(key, f"must be one number or one per lane ({n} = lanes_per_gain x "
                          f"{gains} gain(s)), got {len(vals)} values")
        return tuple(read(key, value=x, lo=lo, hi=hi,
                          what=f"(entry {i} of the list)" if isinstance(v, list) else None)
                     for i, x in enumerate(vals))
    centre = per_lane("eye_centre_taps", 16.0, 0.0, float(N_TAPS - 1))
    width = per_lane("eye_width_taps", ui / tap, 0.0, ui / tap)
    jitter = sec.number("jitter_ps", 0.0, lo=0.0, hi=ui)
    return Lvds(lanes_per_gain=lanes, word_bits=wb, bit_rate_mbps=rate, mapping=mapping,
                train_word=tw, tap_ps=tap, eye_centre_taps=centre, eye_width_taps=width,
                jitter_ps=jitter, skew_bits=per_lane("skew_bits", 0, 0, wb, sec.integer),
                simulate=sec.has("eye_width_taps") or sec.has("jitter_ps")
                or sec.has("drift_taps") or sec.has("skew_bits"),
                eye_status=sec.boolean("eye_status", False),
                drift_taps=per_lane("drift_taps", 0.0, -float(N_TAPS - 1), float(N_TAPS - 1))
                if sec.has("drift_taps") else (),
                drift_frames=sec.integer("drift_frames", 20, lo=1, hi=1 << 20),
                tracking=sec.boolean("tracking", False))


#: ``[optics]``: unit and meaning of every key (:class:`tdicam.blocks.KeyDoc`).
OPTICS_KEYS = {
    "psf_sigma_px": KeyDoc("px", "standard deviation of a Gaussian optics PSF (0: a "
                                 "perfect lens, the optics effect is skipped)"),
}


def read_optics(sec: Section) -> Optics:
    sec.check_keys(("psf_sigma_px",))
    return Optics(psf_sigma_px=sec.number("psf_sigma_px", 0.0, lo=0.0))


#: ``[tdi]``: unit and meaning of every key (:class:`tdicam.blocks.KeyDoc`).
TDI_KEYS = {
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
}


def read_tdi(sec: Section, sensor: Sensor) -> Tdi:
    sec.check_keys(("stages", "domain", "direction", "output", "output_bits"))
    stages = sec.sweep("stages", 1,
                       lambda v, what: sec.integer("stages", value=v, lo=1, what=what))
    return Tdi(stages=stages,
               domain=sec.choice("domain", "digital", ("digital", "charge")),
               direction=sec.choice("direction", "forward", ("forward", "reverse")),
               output=sec.choice("output", "full", ("full", "saturate")),
               output_bits=sec.integer("output_bits", sensor.bits, lo=1, hi=32))


#: ``[motion]``: unit and meaning of every key (:class:`tdicam.blocks.KeyDoc`).
MOTION_KEYS = {
    "dv_over_v": KeyDoc(_FRAC, "relative velocity mismatch dV/V between the image and "
                               "the TDI line clock; a list sweeps it"),
    "drift_deg": KeyDoc("deg", "drift (crab) angle between the flight direction and the "
                               "sensor columns"),
}


def read_motion(sec: Section) -> Motion:
    sec.check_keys(("dv_over_v", "drift_deg"))
    dv = sec.sweep("dv_over_v", 0.0,
                   lambda v, what: sec.number("dv_over_v", value=v, lo=-1.0, hi=1.0,
                                              lo_open=True, hi_open=True, what=what))
    return Motion(dv_over_v=dv,
                  drift_deg=sec.number("drift_deg", 0.0, lo=-90.0, hi=90.0, lo_open=True,
                                       hi_open=True))


#: ``[pipeline]``: unit and meaning of every key (:class:`tdicam.blocks.KeyDoc`).
PIPELINE_KEYS = {
    "blocks": KeyDoc("", "the ordered processing chain, from cds, nuc, hdr, tdi, median3; "
                         "tdi exactly once, no repeats",
                     type="list of strings", range="order rules above"),
    "output": KeyDoc("", "where the generated top's pixels go: stream, the last block's "
                         "AXI4-Stream (m_axis); links, the camera's output links of "
                         "[camera] (links, link_clock_mhz, link_pixel_bits): one frame of "
                         "the sensor's rows in K = frame_rate_hz / output_frame_rate_hz "
                         "kept, framed on TLK2711 parallel ports (link{k}_txd, _tklsb, "
                         "_tkmsb) in the link clock's domain (link_clk, link_rst)",
                     default="stream", range="stream, links; links needs [camera]"),
}

#: ``[pipeline].output`` choices: the top ends in its pixel stream, or in the output links.
OUTPUTS = ("stream", "links")


def read_pipeline(sec: Section, sensor: Sensor, labels) -> Pipeline:
    listed = blocks.scene_blocks()
    with_options = [b for b in listed if b.pipeline.options is not None]
    sec.check_keys(("blocks", "output") + tuple(b.name for b in with_options))
    line_block = next(b.name for b in listed if b.pipeline.lines)
    per_frame = [b.name for b in listed if b.pipeline.per_frame]
    raw = sec.raw("blocks", [line_block])
    if not isinstance(raw, list) or not all(isinstance(b, str) for b in raw):
        sec.fail("blocks", f"must be a list of block names, got {show(raw)}")
    for b in raw:
        if b not in BLOCKS:
            sec.fail("blocks", f"unknown block {b!r}" + hint(b, BLOCKS))
    for b in set(raw):
        if raw.count(b) > 1:
            sec.fail("blocks", f"block {b!r} is listed {raw.count(b)} times; each runs once")
    if line_block not in raw:
        example = [b.name for b in listed if not b.pipeline.merge]
        sec.fail("blocks", f"must contain {line_block!r} once to place the TDI accumulator, "
                           f"e.g. {example}")
    pre = [b for b in raw[:raw.index(line_block) + 1] if b in per_frame or b == line_block]
    wanted = [b for b in per_frame + [line_block] if b in raw]
    if pre != wanted:
        sec.fail("blocks", f"{', '.join(per_frame[:-1])} and {per_frame[-1]} act on single "
                           f"exposures: they must come before {line_block!r} in the order "
                           f"{', '.join(per_frame)}; got {show(raw)}")
    for b in with_options:
        if sec.has(b.name) and b.name not in raw:
            sec.fail(b.name, f"options given but {b.name!r} is not in {sec.label('blocks')}")
    options = []
    for b in with_options:
        opts = b.pipeline.options
        s = Section(f"{sec.name}.{b.name}", sec.data.get(b.name), labels)
        s.check_keys(tuple(opts.keys))
        options.append((b.name, opts.read(s, sensor)))
    return Pipeline(blocks=tuple(raw), options=tuple(options),
                    output=sec.choice("output", "stream", OUTPUTS))


#: ``[camera]``: unit and meaning of every key (:class:`tdicam.blocks.KeyDoc`).
CAMERA_KEYS = {k: KeyDoc(_camera_unit(k), doc, **(
    {"default": "[sensor].max_frame_rate_hz" if k == "frame_rate_hz" else
     "frame_rate_hz"} if d is None else {}))
    for k, (d, _lo, _hi, doc) in camera.KEYS.items()}


def read_camera(sec: Section, sensor: Sensor) -> Camera:
    """``[camera]``: the keys of :data:`tdicam.model.physics.camera.KEYS` (type, default,
    bounds and meaning there); the frame rate defaults to the sensor's."""
    keys = camera.KEYS
    sec.check_keys(tuple(keys))
    got = {}
    for key, (default, lo, hi, _doc) in keys.items():
        if key == "nuc":
            got[key] = sec.choice(key, default, camera.NUC_PLACES)
        elif isinstance(default, int):
            got[key] = sec.integer(key, default, lo=lo, hi=hi)
        elif default is not None:
            got[key] = sec.number(key, default, lo=lo, hi=hi)
    lo, hi = keys["frame_rate_hz"][1:3]
    fps = sec.number("frame_rate_hz", sensor.max_frame_rate_hz, lo=lo, hi=hi)
    if fps is None:
        sec.fail("frame_rate_hz", "missing: give the frame rate the camera reads the sensor "
                                  "at, or [sensor].max_frame_rate_hz")
    top = sensor.max_frame_rate_hz
    if top is not None and fps > top * (1 + 1e-12):
        sec.fail("frame_rate_hz", f"{fps:g} is above the sensor's {top:g} frame/s "
                                  f"([sensor].max_frame_rate_hz)")
    out = sec.number("output_frame_rate_hz", fps, lo=lo, hi=hi)
    if out > fps * (1 + 1e-12):
        sec.fail("output_frame_rate_hz", f"{out:g} is above the {fps:g} frame/s read from "
                                         f"the sensor (frame_rate_hz)")
    if sensor.columns % got["links"]:
        sec.fail("links", f"{got['links']} links do not divide [sensor].columns = "
                          f"{sensor.columns} (each link sends a share of every row)")
    return Camera(frame_rate_hz=fps, output_frame_rate_hz=out, **got)


#: ``[ddr]``: unit and meaning of every key (:class:`tdicam.blocks.KeyDoc`).
DDR_KEYS = {
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
}


def read_ddr(sec: Section) -> Ddr:
    from tdicam.model.dram import DEFAULT_STALLS
    keys = tuple(k for k in DEFAULT_STALLS if k != "seed")
    sec.check_keys(("interface", "base") + keys)
    base = sec.integer("base", 0, lo=0, hi=(1 << 28) - 8)
    if base % 8:
        sec.fail("base", f"must be a multiple of 8 (one address per byte of a 64-bit word), "
                         f"got {base}")
    got = {"refresh_period": sec.integer("refresh_period", DEFAULT_STALLS["refresh_period"],
                                         lo=1, hi=1 << 20),
           "lat_lo": sec.integer("lat_lo", DEFAULT_STALLS["lat_lo"], lo=2, hi=1000),
           "lat_hi": sec.integer("lat_hi", DEFAULT_STALLS["lat_hi"], lo=2, hi=1000),
           "refresh_cycles": sec.integer("refresh_cycles", DEFAULT_STALLS["refresh_cycles"],
                                         lo=0, hi=(1 << 20) - 1),
           "drop": sec.integer("drop", DEFAULT_STALLS["drop"], lo=0, hi=255)}
    for small, big, rule in (("lat_lo", "lat_hi", "<="), ("refresh_cycles", "refresh_period",
                                                          "<")):
        if got[small] > got[big] or (rule == "<" and got[small] == got[big]):
            shown = {k: f"{sec.label(k)} = {got[k]}" + ("" if sec.has(k) else " (the default)")
                     for k in (small, big)}
            raise TdicamError(f"{shown[small]} must be {rule} {shown[big]}")
    stalls = tuple((k, got[k]) for k in keys if got[k] != DEFAULT_STALLS[k])
    return Ddr(interface=sec.choice("interface", "mig", DDR_INTERFACES), base=base,
               stalls=stalls)


#: ``[run]``: unit and meaning of every key (:class:`tdicam.blocks.KeyDoc`).
RUN_KEYS = {
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
}


#: ``[run.rtl].phy``: the generic PHY (words in) or a device PHY simulated from serial bits.
RTL_PHYS = ("generic",) + tuple(p for p in PHYS if p != "none")

#: ``[run.rtl]``: unit and meaning of every key (:class:`tdicam.blocks.KeyDoc`).
RUN_RTL_KEYS = {
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
    "phy": KeyDoc("", "the LVDS receiver's PHY checked from serial bits beside the chain "
                      "(which the generic PHY feeds): the scene's lanes through that "
                      "PHY's receiver, its words against the golden link model's, every "
                      "lane's tap and slip (with eye_status its eye status, with drift and "
                      "tracking every correction; a lane in error as predicted is no "
                      "failure) against the prediction for the PHY",
                  default="generic", range=", ".join(RTL_PHYS) + "; needs [sensor.lvds]; "
                                                              "tracking: xilinx7, 12-bit "
                                                              "words"),
    "csr": KeyDoc("", "the co-simulated top with its control bus (AXI4-Lite, as tdicam "
                      "verilog pipeline writes it by default): the sensor front end's "
                      "status read through the bus while the lanes run, every register "
                      "at the end and each interrupt served in the report (registers, "
                      "irq); false: the top's loose run-time ports",
                  range="true needs [sensor.lvds] (the other tops' bus co-simulation is "
                        "cocotb_tests/test_csr.py)"),
}


def read_run(sec: Section, sensor: Sensor, labels) -> Run:
    sec.check_keys(("lines", "seed", "fidelity", "tolerance", "figure_crop", "rtl"))
    lines = sec.integer("lines", 256, lo=1)
    at = sec.raw("figure_crop", None)
    if at is not None:
        if (not isinstance(at, list) or len(at) != 2
                or not all(isinstance(c, int) and not isinstance(c, bool) for c in at)):
            sec.fail("figure_crop", f"must be two integers [column, line], got {show(at)}")
        if not (0 <= at[0] < sensor.columns and 0 <= at[1] < lines):
            sec.fail("figure_crop", f"must lie inside the {sensor.columns} x {lines} output "
                                    f"([sensor].columns x {sec.label('lines')}), got "
                                    f"{show(at)}")
        at = tuple(at)
    rtl = None
    if sec.has("rtl"):
        r = Section(f"{sec.name}.rtl", sec.data["rtl"], labels)
        r.check_keys(("crop", "simulator", "pixels_per_clock", "lane_dies", "phy", "csr"))
        crop = r.raw("crop", None)
        if crop is not None:
            if (not isinstance(crop, list) or len(crop) != 4
                    or not all(isinstance(c, int) and not isinstance(c, bool) for c in crop)):
                r.fail("crop", f"must be four integers [x0, y0, width, height], got {show(crop)}")
            x0, y0, w, h = crop
            if x0 < 0 or y0 < 0 or w < 1 or h < 1:
                r.fail("crop", f"needs x0, y0 >= 0 and width, height >= 1, got {show(crop)}")
            if x0 + w > sensor.columns or y0 + h > lines:
                r.fail("crop", f"must lie inside the {sensor.columns} x {lines} output "
                               f"([sensor].columns x {sec.label('lines')}), got {show(crop)}")
            crop = tuple(crop)
        ppc = r.integer("pixels_per_clock", 1)
        if ppc not in PPC_CHOICES:
            r.fail("pixels_per_clock", f"must be one of {', '.join(map(str, PPC_CHOICES))}, "
                                       f"got {ppc}")
        width, what = ((sensor.columns, "[sensor].columns") if crop is None
                       else (crop[2], f"{r.label('crop')} width"))
        if width % ppc:
            r.fail("pixels_per_clock", f"{ppc} does not divide the {what} {width}: a beat "
                                       f"carries {ppc} pixels of a line")
        dies = r.raw("lane_dies", None)
        if dies is not None:
            if (not isinstance(dies, list) or len(dies) != 2
                    or not all(isinstance(c, int) and not isinstance(c, bool) for c in dies)):
                r.fail("lane_dies", f"must be two integers [lane, frame], got {show(dies)}")
            if sensor.lvds is None:
                r.fail("lane_dies", "needs the sensor's lanes ([sensor.lvds])")
            n = sensor.lvds.lanes_per_gain * len(sensor.gains)
            if not 0 <= dies[0] < n or dies[1] < 0:
                r.fail("lane_dies", f"needs a lane 0..{n - 1} and a frame >= 0, got "
                                    f"{show(dies)}")
            dies = tuple(dies)
        phy = r.choice("phy", "generic", RTL_PHYS)
        if phy != "generic" and sensor.lvds is None:
            r.fail("phy", f"{phy} needs the sensor's lanes ([sensor.lvds])")
        if phy != "generic" and sensor.lvds.tracking and \
                TRACKING_WORD_BITS.get(phy) != sensor.lvds.word_bits:
            r.fail("phy", f"{phy} with [sensor.lvds].tracking = true and word_bits = "
                          f"{sensor.lvds.word_bits}: the receiver tracks from serial bits "
                          f"only as " + ", ".join(f'{p} with {b}-bit words' for p, b in
                                                  TRACKING_WORD_BITS.items())
                          + " (a monitor sampler); give phy = \"xilinx7\" and word_bits = "
                            "12, or tracking = false")
        csr = r.boolean("csr", False)
        if csr and sensor.lvds is None:
            r.fail("csr", "true needs the sensor's lanes ([sensor.lvds]): tdicam run's bus "
                          "co-simulation is the lanes' top's (give false, or run "
                          "cocotb_tests/test_csr.py for this chain)")
        rtl = RtlRun(crop=crop, simulator=r.choice("simulator", "verilator",
                                                   ("icarus", "verilator")),
                     pixels_per_clock=ppc, lane_dies=dies, phy=phy, csr=csr)
    return Run(lines=lines, seed=sec.integer("seed", 0, lo=0),
               fidelity=sec.choice("fidelity", "auto", FIDELITIES),
               tolerance=sec.number("tolerance", 0.01, lo=0.0, hi=1.0, lo_open=True,
                                    hi_open=True),
               rtl=rtl, figure_crop=at)


#: Unit and meaning of every key, by section (see :class:`tdicam.blocks.KeyDoc`), in the
#: reference page's order; a block's ``[pipeline.<block>]`` keys are its registry entry's
#: (:class:`tdicam.blocks.Options`).
KEYS = {
    "orbit": ORBIT_KEYS,
    "turntable": TURNTABLE_KEYS,
    "target": TARGET_KEYS,
    "sensor": SENSOR_KEYS,
    "optics": OPTICS_KEYS,
    "tdi": TDI_KEYS,
    "motion": MOTION_KEYS,
    "pipeline": PIPELINE_KEYS,
    "ddr": DDR_KEYS,
    "camera": CAMERA_KEYS,
    "run": RUN_KEYS,
    "sensor.lvds": SENSOR_LVDS_KEYS,
    "run.rtl": RUN_RTL_KEYS,
}
