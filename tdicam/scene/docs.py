"""The scene-format reference page (``docs/scene-format.md``), generated from the schema.

The schema is the validating reader :func:`tdicam.scene.loader.scene_from_dict`; there is no second
copy of it. :func:`schema` runs that reader on a set of probe scenes (every section, every
target kind, every pipeline block, the NAND flash store, ``[run.rtl]``, two ADC widths) with
its key readers instrumented, and records for every key the type, default and range the
reader applies, and the keys each section accepts. What the reader cannot say — the meaning
and the unit of a key, and the rule behind a default or bound computed from other keys
(``[sensor].conversion_gain_e_per_dn`` defaults to ``full_well_e / 2**bits``) — is in
:data:`tdicam.scene.sections.KEYS`, each section's beside its reader. :func:`render` fails when the two disagree: a key the
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
from tdicam.blocks import KeyDoc
from tdicam.model.physics import camera
from tdicam.scene import loader, reading, sections

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
              "golden chain does not read it; the gateware reads its links, "
              "link_clock_mhz, link_pixel_bits and the two frame rates only with "
              "[pipeline].output = 'links', which needs their ratio a whole number.",
    "run": "How much to simulate and how exactly.",
    "run.rtl": "Optional: co-simulate the scene's blocks cycle-accurately on a crop of the "
               "output (generated Verilog on Icarus or Verilator) and compare every pixel. "
               "Needs [tdi].domain = \"digital\" (charge-domain TDI has no gateware chain).",
}

KEYS = sections.KEYS

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
    S = reading.Section
    allowed: dict[str, tuple] = {}
    info: dict[tuple, KeyInfo] = {}
    req = reading.REQUIRED

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
          "readers (tdicam/scene/sections.py); tests/test_scenedoc.py checks it is up to date -->", "",
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
