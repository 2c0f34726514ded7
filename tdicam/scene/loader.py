"""Scene files: the reader shared by ``tdicam plan`` and the scene simulator.

A scene is a TOML file (read with :mod:`tomllib`) that describes the platform motion, the
target and its light level, the sensor, TDI, motion errors, the processing pipeline and how
to run the simulation; :mod:`tdicam.scene.schema` states every section, key, default and
range. :func:`load_scene` validates a file completely and returns a frozen :class:`Scene`;
every error is one line that names the offending key, e.g. ``[sensor].read_noise_e: must be
>= 0, got -1``. Unknown sections and keys are errors, with a did-you-mean hint when a valid
name is close. One validating reader per section lives here, next to the cross-section
checks (stages against the window limit, the line period, the output's extent).
"""

from __future__ import annotations

import copy
import dataclasses
import difflib
import math
import numbers
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from tdicam import blocks
from tdicam.beats import PPC_CHOICES
from tdicam.blocks import steps as _steps
from tdicam.errors import TdicamError, api_arguments, check_choice, check_range
from tdicam.model import lvds_front
from tdicam.scene.keys import check_key, set_key
from tdicam.model.physics import camera
from tdicam.model.physics.camera import Camera
from tdicam.model.lvds import N_TAPS, PAPER_TAP_PS, default_train_word, rotations
from tdicam.model.physics import plan as _plan, targets as _targets
from tdicam.scene.schema import (BLOCKS, BOUNDS, BUNDLED_IMAGES, DDR_INTERFACES, FIDELITIES,
                                 TARGET_KINDS, Ddr, Lvds, Motion, Optics, Orbit, Pipeline, RtlRun,
                                 Run, Sensor, TargetSpec, Tdi, Turntable)

__all__ = [
    "read_toml",
    "BOUNDS",
    "BUNDLED_IMAGES",
    "TARGET_KINDS",
    "BLOCKS",
    "Orbit",
    "Turntable",
    "TargetSpec",
    "digital_tdi_limits_error",
    "Sensor",
    "Optics",
    "Tdi",
    "Motion",
    "Pipeline",
    "RtlRun",
    "Run",
    "Scene",
    "load_scene",
    "scene_from_dict",
]

_SECTIONS = ("orbit", "turntable", "target", "sensor", "optics", "tdi", "motion", "pipeline",
             "ddr", "run", "camera")
_IMAGE_SUFFIXES = (".png", ".tif", ".tiff")
_KIND_KEYS = {
    "image": ("image", "path"),
    "bars": ("period_px", "contrast", "direction", "profile"),
    "edge": ("contrast", "angle_deg"),
    "siemens": ("contrast", "spokes"),
    "flat": (),
}
_REQUIRED = object()


@dataclass(frozen=True)
class Scene:
    """A validated scene. Exactly one of ``orbit`` and ``turntable`` is set."""

    orbit: Orbit | None
    turntable: Turntable | None
    target: TargetSpec
    sensor: Sensor
    tdi: Tdi
    motion: Motion
    pipeline: Pipeline
    run: Run
    source: str = "<dict>"
    optics: Optics = Optics()
    ddr: Ddr | None = None
    camera: Camera | None = None

    @property
    def line_period_s(self) -> float:
        """TDI line period from the orbit (``gsd / v_g``) or turntable (``a / (omega l)``)."""
        if self.orbit is not None:
            return self.orbit.line_period_s
        return float(_plan.turntable_line_period(self.sensor.pitch_m,
                                                 self.turntable.angular_speed_rad_s,
                                                 self.turntable.distance_m))

    @property
    def timing(self) -> _plan.RollingTiming | None:
        """Window timing (n_lines, T_back, M0) when the sensor's row time is known."""
        t_row = self.sensor.row_time_s
        if t_row is None:
            return None
        return _plan.rolling_timing(self.line_period_s, t_row, self.sensor.rows)

    @classmethod
    @api_arguments
    def load(cls, path: str | Path, *, overrides: Mapping[str, Any] | None = None) -> Scene:
        """Read and validate a scene TOML file (:func:`load_scene`).

        Parameters
        ----------
        path : str or Path
            The scene file (``docs/scene-format.md`` lists every key).
        overrides : mapping, optional
            ``{section: {key: value}}`` applied over the file before validation.

        Returns
        -------
        Scene

        Raises
        ------
        TdicamError
            The file is missing or not TOML, or a key is invalid (one line naming it).
        """
        if path is None:
            raise TdicamError("Scene.load: path: a scene file name is needed (Scene.example "
                              "NAME gives a bundled scene, Scene.from_dict a dict)")
        return load_scene(path, overrides=overrides)

    @classmethod
    @api_arguments
    def from_dict(cls, data: Mapping[str, Any], *, base_dir: str | Path | None = None
                  ) -> Scene:
        """Validate a scene given as a dict (what :func:`tomllib.loads` makes of a scene
        file; :func:`scene_from_dict`).

        Parameters
        ----------
        data : mapping
            ``{section: {key: value}}``, as in a scene file.
        base_dir : str or Path, optional
            Folder relative ``[target].path`` pictures are found in (default: the current
            folder).

        Returns
        -------
        Scene

        Raises
        ------
        TdicamError
            A key is invalid (one line naming it).
        """
        if base_dir is not None:
            from tdicam.files import input_path
            base_dir = input_path(base_dir, "Scene.from_dict: base_dir")
        return scene_from_dict(data, base_dir=base_dir)

    @classmethod
    @api_arguments
    def example(cls, name: str) -> Scene:
        """A bundled scene by name (``tdicam scenes`` lists them).

        Parameters
        ----------
        name : str
            E.g. ``"orbit_600km_1m_96"``.

        Returns
        -------
        Scene

        Raises
        ------
        TdicamError
            No bundled scene has that name.
        """
        from tdicam.scene.examples import example_path
        return load_scene(example_path(name))

    @api_arguments
    def replace(self, changes: Mapping[str, Any]) -> Scene:
        """This scene with some of its keys changed, validated again as a file with those
        values would be (every check of the reader; the original is unchanged).

        Parameters
        ----------
        changes : mapping of str to value
            ``{"section.key": value}``, as a sweep names keys (``{"sensor.read_noise_e": 5,
            "run.rtl.pixels_per_clock": 2}``); a value of None removes the key (its default
            applies again).

        Returns
        -------
        Scene

        Raises
        ------
        TdicamError
            A key that is not a ``section.key`` path, an unknown key or a bad value (one
            line naming it), or a scene that was not read by tdicam (made with
            :func:`dataclasses.replace`: it has no scene table to change).
        """
        if not isinstance(changes, Mapping):
            raise TdicamError(f"Scene.replace: changes: expected a mapping of 'section.key' to "
                              f"values, e.g. {{'sensor.read_noise_e': 5}}, got "
                              f"{type(changes).__name__}")
        data, base_dir, window = self._given("Scene.replace")
        data = copy.deepcopy(data)
        for key, value in changes.items():
            set_key(data, check_key(key, "Scene.replace"), value)
        return scene_from_dict(data, base_dir=base_dir, source=self.source, window=window)

    def _given(self, what):
        """(the scene table it was read from, its base folder, its window check)."""
        given = getattr(self, "_input", None)
        if given is None:
            raise TdicamError(f"{what}: this Scene was not read by tdicam (Scene.load, "
                              f"from_dict or example), so it has no scene table to change")
        return given

    @api_arguments
    def with_run(self, *, lines: int | None = None, seed: int | None = None,
                 fidelity: str | None = None) -> Scene:
        """This scene with ``[run].lines``, ``[run].seed`` and/or ``[run].fidelity``
        replaced.

        Parameters
        ----------
        lines : int, optional
            Output lines, checked as the reader checks ``[run].lines`` (at most
            :data:`MAX_OUTPUT_PIXELS` output pixels, two bar periods along track, the
            ``[run.rtl]`` crop inside).
        seed : int, optional
            Seed of every random draw, >= 0.
        fidelity : {"exact", "fast", "auto"}, optional
            The scene simulator's fidelity (``[run].fidelity``).

        Returns
        -------
        Scene

        Raises
        ------
        TdicamError
            A value out of its range (one line naming ``lines`` or ``seed``).
        """
        run = self.run
        if seed is not None:
            run = dataclasses.replace(run, seed=check_range("seed", seed, 0, None))
        if lines is not None:
            cols = self.sensor.columns
            lines = check_range("lines", lines, 1, MAX_OUTPUT_PIXELS // cols)
            t = self.target
            if t.kind == "bars" and t.direction == "along_track" and t.period_px > lines / 2:
                raise TdicamError(f"lines = {lines}: fewer than two periods of the "
                                  f"{t.period_px:g}-px bars along track")
            crop = run.rtl.crop if run.rtl is not None else None
            if crop is not None and crop[1] + crop[3] > lines:
                raise TdicamError(f"lines = {lines}: the [run.rtl] crop {list(crop)} does not "
                                  f"fit")
            run = dataclasses.replace(run, lines=lines)
        if fidelity is not None:
            run = dataclasses.replace(run, fidelity=check_choice("fidelity", fidelity,
                                                                 FIDELITIES))
        new = dataclasses.replace(self, run=run)
        given = getattr(self, "_input", None)
        if given is not None:           # the scene table follows, so replace() keeps them
            data = copy.deepcopy(given[0])
            for key, value in (("lines", lines), ("seed", seed), ("fidelity", fidelity)):
                if value is not None:
                    set_key(data, f"run.{key}", getattr(run, key))
            object.__setattr__(new, "_input", (data, *given[1:]))
        return new

    def to_dict(self) -> dict:
        """Plain JSON-serialisable dict of the validated scene (paths as strings)."""
        def conv(value):
            if isinstance(value, Path):
                return str(value)
            if isinstance(value, tuple):
                return [conv(v) for v in value]
            if isinstance(value, dict):
                return {k: conv(v) for k, v in value.items()}
            return value
        d = conv(dataclasses.asdict(self))
        if d["sensor"]["lvds"] is None:     # ideal lanes: the dict of before
            del d["sensor"]["lvds"]
        else:                               # eye status, drift, tracking off: as before
            lv = d["sensor"]["lvds"]
            for key, off in (("eye_status", False), ("drift_taps", []), ("drift_frames", 20),
                             ("tracking", False)):
                if lv[key] == off:
                    del lv[key]
        rtl = d["run"]["rtl"]
        if rtl is not None and rtl["lane_dies"] is None:      # no fault: the dict of before
            del rtl["lane_dies"]
        if d["camera"] is None:             # no camera budget: the dict of before
            del d["camera"]
        if d["run"]["figure_crop"] is None:     # a centred crop: the dict of before
            del d["run"]["figure_crop"]
        if d.get("ddr") is not None:        # the model's stall pattern, as given
            stalls = d["ddr"].pop("stalls")
            d["ddr"].update({k: v for k, v in stalls})
        return d


# --------------------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------------------


def _show(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "[" + ", ".join(_show(v) for v in value) + "]"
    return str(value)



def _hint(key, valid) -> str:
    close = difflib.get_close_matches(key, list(valid), n=1, cutoff=0.6)
    if close:
        return f"; did you mean {close[0]!r}?"
    return "; valid: " + ", ".join(valid) if valid else ""


class _Section:
    """One TOML table being validated; errors name ``[section].key`` (or a CLI label)."""

    def __init__(self, name: str, data: Any, labels: Mapping[str, str]):
        self.name = name
        self.labels = labels
        if data is None:
            data = {}
        if not isinstance(data, dict):
            raise TdicamError(f"{self.section_label()}: must be a table, got {_show(data)}")
        self.data = data

    def section_label(self) -> str:
        return self.labels.get(self.name, f"[{self.name}]")

    def label(self, key: str) -> str:
        return self.labels.get(f"{self.name}.{key}", f"[{self.name}].{key}")

    def fail(self, key: str, message: str):
        raise TdicamError(f"{self.label(key)}: {message}")

    def has(self, key: str) -> bool:
        return key in self.data

    def check_keys(self, allowed) -> None:
        for key in self.data:
            if key not in allowed:
                self.fail(key, "unknown key" + _hint(key, sorted(allowed)))

    def raw(self, key, default):
        if key in self.data:
            return self.data[key]
        if default is _REQUIRED:
            self.fail(key, "missing (required)")
        return default

    def number(self, key, default=_REQUIRED, *, lo=None, hi=None, lo_open=False,
               hi_open=False, value=_REQUIRED, what=None):
        v = self.raw(key, default) if value is _REQUIRED else value
        if v is None:
            return None
        where = f" {what}" if what else ""
        if isinstance(v, bool) or not isinstance(v, numbers.Real):
            self.fail(key, f"must be a number{where}, got {_show(v)}")
        if not isinstance(v, (int, float)):         # numpy numbers
            v = int(v) if isinstance(v, numbers.Integral) else float(v)
        raw, shown, v = v, _show(v), float(v)
        if not math.isfinite(v):
            self.fail(key, f"must be a finite number{where}, got {shown}")
        bound = BOUNDS.get(f"{self.name}.{key}")
        if bound is not None:           # a physical bound replaces "positive"
            (lo, hi), lo_open, hi_open = bound, False, False
        check_range(f"{self.label(key)}{where}", raw, lo, hi, integer=False,
                    lo_open=lo_open, hi_open=hi_open)
        return v

    def integer(self, key, default=_REQUIRED, *, lo=None, hi=None, value=_REQUIRED, what=None):
        v = self.raw(key, default) if value is _REQUIRED else value
        if v is None:
            return None
        where = f" {what}" if what else ""
        # numpy integers are integers (a Python caller's numpy.int64(16))
        if isinstance(v, bool) or not isinstance(v, numbers.Integral):
            self.fail(key, f"must be an integer{where}, got {_show(v)}")
        v = int(v)
        lo, hi = BOUNDS.get(f"{self.name}.{key}", (lo, hi))
        return check_range(f"{self.label(key)}{where}", v, lo, hi)

    def choice(self, key, default, choices):
        v = self.raw(key, default)
        if not isinstance(v, str) or v not in choices:
            hint = ""
            if isinstance(v, str):
                close = difflib.get_close_matches(v, list(choices), n=1, cutoff=0.6)
                hint = f"; did you mean {close[0]!r}?" if close else ""
            self.fail(key, "must be one of " + ", ".join(repr(c) for c in choices)
                      + f", got {_show(v)}{hint}")
        return v

    def boolean(self, key, default):
        v = self.raw(key, default)
        if not isinstance(v, bool):
            self.fail(key, f"must be true or false, got {_show(v)}")
        return v

    def string(self, key, default=_REQUIRED):
        v = self.raw(key, default)
        if v is not None and not isinstance(v, str):
            self.fail(key, f"must be a string, got {_show(v)}")
        return v

    def sweep(self, key, default, item):
        """A scalar or a non-empty list; ``item(value, what)`` validates each entry."""
        v = self.raw(key, default)
        if isinstance(v, list):
            if not v:
                self.fail(key, "must not be an empty list")
            out = tuple(item(x, f"(entry {i} of the list)") for i, x in enumerate(v))
            twice = [x for i, x in enumerate(out) if x in out[:i]]
            if twice:
                self.fail(key, f"lists {_show(twice[0])} more than once, got {_show(v)}; "
                               f"each value of a sweep once")
            return out
        return (item(v, None),)


# --------------------------------------------------------------------------------------
# sections
# --------------------------------------------------------------------------------------


def _orbit(sec: _Section) -> Orbit:
    sec.check_keys(("altitude_km", "gsd_m"))
    return Orbit(altitude_km=sec.number("altitude_km"), gsd_m=sec.number("gsd_m"))


def _turntable(sec: _Section) -> Turntable:
    sec.check_keys(("angular_speed_rad_s", "distance_m"))
    return Turntable(angular_speed_rad_s=sec.number("angular_speed_rad_s"),
                     distance_m=sec.number("distance_m"))


def _target(sec: _Section, base_dir: Path) -> TargetSpec:
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
                                  + _hint(name, BUNDLED_IMAGES))
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


_SENSOR_KEYS = ("columns", "rows", "pitch_um", "fill_factor", "bits", "full_well_e",
                "conversion_gain_e_per_dn", "read_noise_e", "dark_current_e_per_s", "prnu",
                "dsnu_e", "shutter", "row_blanking_us", "pixel_clock_mhz",
                "max_frame_rate_hz", "gains", "black_level_dn", "lvds")


def _sensor(sec: _Section) -> Sensor:
    sec.check_keys(_SENSOR_KEYS)
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
        sec.fail("gains", f"must be a list of one or two gains, got {_show(gains_raw)}")
    gains = tuple(sec.number("gains", value=g, lo=0.0, lo_open=True, hi=1e6,  # 1e308: inf
                             what=f"(entry {i} of the list)")
                  for i, g in enumerate(gains_raw))
    if len(gains) == 2 and not gains[0] > gains[1]:
        sec.fail("gains", f"two gains must be [high, low] with high > low, got {_show(gains_raw)}")
    columns = sec.integer("columns", 1280)
    lvds = None
    if sec.has("lvds"):
        lvds = _lvds(_Section(f"{sec.name}.lvds", sec.data["lvds"], sec.labels), columns, bits,
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


def _lvds(sec: _Section, columns: int, bits: int, gains: int, rows: int) -> Lvds:
    sec.check_keys(("lanes_per_gain", "word_bits", "bit_rate_mbps", "mapping", "train_word",
                    "tap_ps", "eye_centre_taps", "eye_width_taps", "jitter_ps", "eye_status",
                    "drift_taps", "drift_frames", "tracking"))
    dflt = lvds_front.GMAX0504
    lanes = sec.integer("lanes_per_gain", dflt["lanes_per_gain"], lo=1, hi=128)
    if columns % lanes:
        given = "" if sec.has("lanes_per_gain") else " (the default, the GMAX0504's; give it)"
        sec.fail("lanes_per_gain", f"{lanes}{given} does not divide [sensor].columns = "
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

    def per_lane(key, default, lo, hi):
        v = sec.raw(key, default)
        vals = v if isinstance(v, list) else [v] * n
        if len(vals) != n:
            sec.fail(key, f"must be one number or one per lane ({n} = lanes_per_gain x "
                          f"{gains} gain(s)), got {len(vals)} values")
        return tuple(sec.number(key, value=x, lo=lo, hi=hi,
                                what=f"(entry {i} of the list)" if isinstance(v, list) else None)
                     for i, x in enumerate(vals))
    centre = per_lane("eye_centre_taps", 16.0, 0.0, float(N_TAPS - 1))
    width = per_lane("eye_width_taps", ui / tap, 0.0, ui / tap)
    jitter = sec.number("jitter_ps", 0.0, lo=0.0, hi=ui)
    return Lvds(lanes_per_gain=lanes, word_bits=wb, bit_rate_mbps=rate, mapping=mapping,
                train_word=tw, tap_ps=tap, eye_centre_taps=centre, eye_width_taps=width,
                jitter_ps=jitter, simulate=sec.has("eye_width_taps") or sec.has("jitter_ps")
                or sec.has("drift_taps"),
                eye_status=sec.boolean("eye_status", False),
                drift_taps=per_lane("drift_taps", 0.0, -float(N_TAPS - 1), float(N_TAPS - 1))
                if sec.has("drift_taps") else (),
                drift_frames=sec.integer("drift_frames", 20, lo=1, hi=1 << 20),
                tracking=sec.boolean("tracking", False))


def _optics(sec: _Section) -> Optics:
    sec.check_keys(("psf_sigma_px",))
    return Optics(psf_sigma_px=sec.number("psf_sigma_px", 0.0, lo=0.0))


def _tdi(sec: _Section, sensor: Sensor) -> Tdi:
    sec.check_keys(("stages", "domain", "direction", "output", "output_bits"))
    stages = sec.sweep("stages", 1,
                       lambda v, what: sec.integer("stages", value=v, lo=1, what=what))
    return Tdi(stages=stages,
               domain=sec.choice("domain", "digital", ("digital", "charge")),
               direction=sec.choice("direction", "forward", ("forward", "reverse")),
               output=sec.choice("output", "full", ("full", "saturate")),
               output_bits=sec.integer("output_bits", sensor.bits, lo=1, hi=32))


def _motion(sec: _Section) -> Motion:
    sec.check_keys(("dv_over_v", "drift_deg"))
    dv = sec.sweep("dv_over_v", 0.0,
                   lambda v, what: sec.number("dv_over_v", value=v, lo=-1.0, hi=1.0,
                                              lo_open=True, hi_open=True, what=what))
    return Motion(dv_over_v=dv,
                  drift_deg=sec.number("drift_deg", 0.0, lo=-90.0, hi=90.0, lo_open=True,
                                       hi_open=True))


def _pipeline(sec: _Section, sensor: Sensor, labels) -> Pipeline:
    listed = blocks.scene_blocks()
    with_options = [b for b in listed if b.pipeline.options is not None]
    sec.check_keys(("blocks",) + tuple(b.name for b in with_options))
    line_block = next(b.name for b in listed if b.pipeline.lines)
    per_frame = [b.name for b in listed if b.pipeline.per_frame]
    raw = sec.raw("blocks", [line_block])
    if not isinstance(raw, list) or not all(isinstance(b, str) for b in raw):
        sec.fail("blocks", f"must be a list of block names, got {_show(raw)}")
    for b in raw:
        if b not in BLOCKS:
            sec.fail("blocks", f"unknown block {b!r}" + _hint(b, BLOCKS))
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
                           f"{', '.join(per_frame)}; got {_show(raw)}")
    for b in with_options:
        if sec.has(b.name) and b.name not in raw:
            sec.fail(b.name, f"options given but {b.name!r} is not in {sec.label('blocks')}")
    options = []
    for b in with_options:
        opts = b.pipeline.options
        s = _Section(f"{sec.name}.{b.name}", sec.data.get(b.name), labels)
        s.check_keys(tuple(opts.keys))
        options.append((b.name, opts.read(s, sensor)))
    return Pipeline(blocks=tuple(raw), options=tuple(options))


def _camera(sec: _Section, sensor: Sensor) -> Camera:
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


def _ddr(sec: _Section) -> Ddr:
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


def _run(sec: _Section, sensor: Sensor, labels) -> Run:
    sec.check_keys(("lines", "seed", "fidelity", "tolerance", "figure_crop", "rtl"))
    lines = sec.integer("lines", 256, lo=1)
    at = sec.raw("figure_crop", None)
    if at is not None:
        if (not isinstance(at, list) or len(at) != 2
                or not all(isinstance(c, int) and not isinstance(c, bool) for c in at)):
            sec.fail("figure_crop", f"must be two integers [column, line], got {_show(at)}")
        if not (0 <= at[0] < sensor.columns and 0 <= at[1] < lines):
            sec.fail("figure_crop", f"must lie inside the {sensor.columns} x {lines} output "
                                    f"([sensor].columns x {sec.label('lines')}), got "
                                    f"{_show(at)}")
        at = tuple(at)
    rtl = None
    if sec.has("rtl"):
        r = _Section(f"{sec.name}.rtl", sec.data["rtl"], labels)
        r.check_keys(("crop", "simulator", "pixels_per_clock", "lane_dies"))
        crop = r.raw("crop", None)
        if crop is not None:
            if (not isinstance(crop, list) or len(crop) != 4
                    or not all(isinstance(c, int) and not isinstance(c, bool) for c in crop)):
                r.fail("crop", f"must be four integers [x0, y0, width, height], got {_show(crop)}")
            x0, y0, w, h = crop
            if x0 < 0 or y0 < 0 or w < 1 or h < 1:
                r.fail("crop", f"needs x0, y0 >= 0 and width, height >= 1, got {_show(crop)}")
            if x0 + w > sensor.columns or y0 + h > lines:
                r.fail("crop", f"must lie inside the {sensor.columns} x {lines} output "
                               f"([sensor].columns x {sec.label('lines')}), got {_show(crop)}")
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
                r.fail("lane_dies", f"must be two integers [lane, frame], got {_show(dies)}")
            if sensor.lvds is None:
                r.fail("lane_dies", "needs the sensor's lanes ([sensor.lvds])")
            n = sensor.lvds.lanes_per_gain * len(sensor.gains)
            if not 0 <= dies[0] < n or dies[1] < 0:
                r.fail("lane_dies", f"needs a lane 0..{n - 1} and a frame >= 0, got "
                                    f"{_show(dies)}")
            dies = tuple(dies)
        rtl = RtlRun(crop=crop, simulator=r.choice("simulator", "verilator",
                                                   ("icarus", "verilator")),
                     pixels_per_clock=ppc, lane_dies=dies)
    return Run(lines=lines, seed=sec.integer("seed", 0, lo=0),
               fidelity=sec.choice("fidelity", "auto", FIDELITIES),
               tolerance=sec.number("tolerance", 0.01, lo=0.0, hi=1.0, lo_open=True,
                                    hi_open=True),
               rtl=rtl, figure_crop=at)


def _check_stages(sec: _Section, scene: Scene, window: bool = True) -> None:
    rows = scene.sensor.rows
    for m in scene.tdi.stages:
        if m > rows:
            sec.fail("stages", f"must be <= {rows} (the sensor rows, "
                               f"{sec.labels.get('sensor.rows', '[sensor].rows')}), got {m}")
    timing = scene.timing
    if timing is None or not window:
        return
    t_line_us, t_row_us = timing.line_period_s * 1e6, timing.row_time_s * 1e6
    if timing.m0 == 0:
        sec.fail("stages", f"no TDI is possible: the row time {t_row_us:.4g} us exceeds the "
                           f"line period {t_line_us:.4g} us (M0 = 0)")
    for m in scene.tdi.stages:
        if m > timing.m0:
            sec.fail("stages", f"must be <= M0 = {timing.m0} (rows read in one line period: "
                               f"T_line {t_line_us:.4g} us / T_row {t_row_us:.4g} us), got {m}")


def digital_tdi_limits_error(scene: Scene, stages) -> str | None:
    """Why digital TDI of ``stages`` stages cannot run on ``scene``'s pixels (None: it can).

    The one rule for every fidelity (exact runs the golden accumulator
    :func:`tdicam.model.tdi.tdi`; fast must not accept what exact refuses): at most
    :data:`tdicam.model.tdi.MAX_STAGES` stages, and, when the ADC feeds TDI directly (no hdr
    merge in between), ``[sensor].bits`` in :data:`tdicam.model.tdi.PIXEL_BITS`.
    """
    from tdicam.model import tdi
    if scene.tdi.domain != "digital":
        return None
    if stages > tdi.MAX_STAGES:
        return (f"stages: must be <= {tdi.MAX_STAGES} for digital TDI (the "
                f"accumulator's limit), got {stages}")
    lo, hi = tdi.PIXEL_BITS
    hdr = len(scene.sensor.gains) == 2 and any(blocks.get(b).pipeline.merge
                                               for b in scene.pipeline.blocks)
    if not hdr and not lo <= scene.sensor.bits <= hi:
        return (f"bits: digital TDI takes {lo}..{hi}-bit pixels (the accumulator's range), "
                f"got {scene.sensor.bits}")
    if hdr:
        # the merge (before TDI: the order rules) widens the pixels by the gain ratio: TDI
        # must take what it gives; the merge block's step says how wide
        merge = next(b for b in scene.pipeline.blocks if blocks.get(b).pipeline.merge)
        g = scene.sensor.gains
        ctx = _steps.StepContext(scene=scene, m=stages, width=scene.sensor.columns, lines=0,
                                 bits=scene.sensor.bits, block=merge)
        try:
            _, out = blocks.get(merge).pipeline.step(ctx)
        except TdicamError as exc:
            return f"gains: {list(g)} for the {merge} merge: {exc}"
        if not lo <= out <= hi:
            return (f"gains: {list(g)} with [sensor].bits = {scene.sensor.bits}: the {merge} "
                    f"merge gives {out}-bit pixels and digital TDI takes {lo}..{hi}-bit "
                    f"pixels (lower the gain ratio or the bits)")
    return None


def _check_digital_tdi(tdi_sec: _Section, sensor_sec: _Section, scene: Scene) -> None:
    for m in scene.tdi.stages:
        why = digital_tdi_limits_error(scene, m)
        if why is not None:
            key, _, msg = why.partition(": ")
            (tdi_sec if key == "stages" else sensor_sec).fail(key, msg)


def _check_chain(sec: _Section, scene: Scene, labels) -> None:
    """What the scene simulator would refuse after its work, refused here: a memory the
    scene places in DDR without a ``[ddr]`` section, TDI output too wide for median3 after
    it, more front-end lanes than the front takes (both gains with a merging block)."""
    from tdicam.blocks.lvds import MAX_LANES
    from tdicam.blocks.median3 import check_after_tdi
    names = list(scene.pipeline.blocks)
    for b in names:
        use = blocks.get(b).pipeline
        if use.placement is not None and scene.ddr is None and use.placement(scene) == "ddr":
            raise TdicamError(f"{labels.get(f'pipeline.{b}.memory', f'[pipeline.{b}].memory')} "
                              f"= 'ddr' keeps its {use.memory} in DDR, but the scene has no "
                              f"[ddr] section (the DDR interface it uses): add [ddr] "
                              f"(interface = \"mig\") or set memory = 'chip'")
    lv = scene.sensor.lvds
    merge = any(blocks.get(b).pipeline.merge for b in names)
    if lv is not None and merge and lv.lanes_per_gain * len(scene.sensor.gains) > MAX_LANES:
        n = len(scene.sensor.gains)
        raise TdicamError(f"{labels.get('sensor.lvds.lanes_per_gain', '[sensor.lvds].lanes_per_gain')}"
                          f" = {lv.lanes_per_gain} on {n} gains merged by the chain is "
                          f"{lv.lanes_per_gain * n} lanes; the front end takes at most "
                          f"{MAX_LANES}: lanes_per_gain <= {MAX_LANES // n}")
    line = [b for b in names if blocks.get(b).pipeline.lines]
    if scene.tdi.domain != "digital" or not line or line[0] == names[-1]:
        return
    for m in scene.tdi.stages:
        bits = scene.sensor.bits
        try:
            if merge:
                mb = next(b for b in names if blocks.get(b).pipeline.merge)
                _, bits = blocks.get(mb).pipeline.step(_steps.StepContext(
                    scene=scene, m=m, width=scene.sensor.columns, lines=0, bits=bits, block=mb))
            _, out = blocks.get(line[0]).pipeline.step(_steps.StepContext(
                scene=scene, m=m, width=scene.sensor.columns, lines=0, bits=bits,
                block=line[0]))
        except TdicamError:
            return      # a chain the gateware cannot build: its plan (or Verilog) says why
        check_after_tdi(out, names[names.index(line[0]) + 1:])


# --------------------------------------------------------------------------------------
# public entry points
# --------------------------------------------------------------------------------------


def scene_from_dict(data: Mapping[str, Any], *, base_dir: str | Path | None = None,
                    source: str = "<dict>",
                    labels: Mapping[str, str] | None = None, window: bool = True) -> Scene:
    """Validate a parsed scene (the dict :func:`tomllib.load` returns) into a :class:`Scene`.

    Parameters
    ----------
    data : mapping
        Top-level tables keyed by section name.
    base_dir : str or Path, optional
        Directory that relative ``[target].path`` values are resolved against (default:
        the current directory).
    source : str, optional
        Where the data came from, kept in :attr:`Scene.source`.
    labels : mapping, optional
        Replaces ``[section].key`` in error messages, keyed by ``"section.key"`` (e.g.
        ``{"tdi.stages": "--stages"}`` when a value came from the command line).
    window : bool, optional
        Refuse stage counts above the rolling-shutter window ``M0`` (default). ``tdicam
        plan`` turns it off: a window too short is its feasibility report's answer, NO.

    Returns
    -------
    Scene

    Raises
    ------
    TdicamError
        One line naming the first offending key.
    """
    labels = dict(labels or {})
    if not isinstance(data, Mapping):
        raise TdicamError(f"{source}: a scene must be a table of sections")
    for name in data:
        if not isinstance(name, str):
            raise TdicamError(f"{source}: section names must be strings, got {name!r}")
        if name not in _SECTIONS:
            raise TdicamError(f"[{name}]: unknown section" + _hint(name, _SECTIONS))
    if ("orbit" in data) == ("turntable" in data):
        which = "both" if "orbit" in data else "neither"
        raise TdicamError(f"{labels.get('orbit', '[orbit]')}: a scene needs exactly one of "
                          f"[orbit] and [turntable], got {which}")
    base = Path.cwd() if base_dir is None else Path(base_dir)

    def section(name):
        return _Section(name, data.get(name), labels)

    orbit = _orbit(section("orbit")) if "orbit" in data else None
    turntable = _turntable(section("turntable")) if "turntable" in data else None
    target = _target(section("target"), base)
    sensor = _sensor(section("sensor"))
    optics = _optics(section("optics"))
    tdi_sec = section("tdi")
    tdi = _tdi(tdi_sec, sensor)
    motion = _motion(section("motion"))
    pipeline = _pipeline(section("pipeline"), sensor, labels)
    run = _run(section("run"), sensor, labels)
    ddr = _ddr(section("ddr")) if "ddr" in data else None
    cam = _camera(section("camera"), sensor) if "camera" in data else None
    scene = Scene(orbit=orbit, turntable=turntable, target=target, sensor=sensor, tdi=tdi,
                  motion=motion, pipeline=pipeline, run=run, source=source, optics=optics,
                  ddr=ddr, camera=cam)
    # what it was read from, for Scene.replace (not a field: not compared, not in to_dict)
    object.__setattr__(scene, "_input", (copy.deepcopy(dict(data)), base_dir, window))
    _check_stages(tdi_sec, scene, window)
    _check_digital_tdi(tdi_sec, section("sensor"), scene)
    _check_chain(section("pipeline"), scene, labels)
    _check_extent(section("target"), section("run"), scene)
    _check_line_period(section("orbit" if orbit is not None else "turntable"), scene)
    if run.rtl is not None and tdi.domain != "digital":
        raise TdicamError(f"{labels.get('run.rtl', '[run.rtl]')}: needs "
                          f"{tdi_sec.label('domain')} = 'digital' (charge-domain TDI sums in "
                          f"the sensor: there is no gateware chain to co-simulate)")
    return scene


#: The line period a scene may derive, seconds (inclusive): 10 ns (a 100 MHz line rate)
#: to 100 s. Each key has its own bound (:data:`BOUNDS`); this one catches combinations
#: no camera runs at (a 0.1 um pixel on a 1000 rad/s turntable at 1 km; 1 mm on a
#: 1e-6 rad/s one at 1 mm).
LINE_PERIOD_S = (1e-8, 100.0)


def _check_line_period(sec: _Section, scene: Scene) -> None:
    t = scene.line_period_s
    lo, hi = LINE_PERIOD_S
    if not lo <= t <= hi:
        keys = (f"{sec.label('altitude_km')} and {sec.label('gsd_m')}"
                if scene.orbit is not None else
                f"{sec.label('angular_speed_rad_s')}, {sec.label('distance_m')} and "
                f"{sec.labels.get('sensor.pitch_um', '[sensor].pitch_um')}")
        raise TdicamError(f"the line period {t:.4g} s from {keys} is out of range; valid: "
                          f"{lo:g}..{hi:g} s")


#: Output pixels (``[sensor].columns x [run].lines``) a run may have at most: the scene
#: simulator keeps the whole output (and per-stage work arrays) in memory.
MAX_OUTPUT_PIXELS = 1 << 27


def _check_extent(target_sec: _Section, run_sec: _Section, scene: Scene) -> None:
    """The output fits in memory, and a bar chart shows two periods across its axis."""
    cols, lines = scene.sensor.columns, scene.run.lines
    if cols * lines > MAX_OUTPUT_PIXELS:
        run_sec.fail("lines", f"{cols} columns x {lines} lines = {cols * lines} output pixels, "
                              f"more than the {MAX_OUTPUT_PIXELS} the simulator holds in "
                              f"memory; simulate at most {MAX_OUTPUT_PIXELS // cols} lines")
    t = scene.target
    if t.kind == "bars":
        extent, what = ((lines, run_sec.label("lines")) if t.direction == "along_track"
                        else (cols, "[sensor].columns"))
        if t.period_px > extent / 2:
            target_sec.fail("period_px", f"must be <= {extent / 2:g} (two bar periods across "
                                         f"the {extent} px of {what}), got {t.period_px:g}; "
                                         f"or make {what} >= {math.ceil(2 * t.period_px)}")


def _merge(base: dict, overrides: Mapping[str, Any]) -> dict:
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.items()}
    for name, table in overrides.items():
        if table is None:
            out.pop(name, None)
        elif isinstance(table, Mapping):
            merged = dict(out[name]) if isinstance(out.get(name), dict) else {}
            merged.update(table)
            out[name] = {k: v for k, v in merged.items() if v is not None}
        else:
            out[name] = table
    return out


def read_toml(path, what):
    """The TOML file ``path`` as a dict, or a one-line :class:`TdicamError` naming ``what``
    (e.g. ``"scene file"``) and the problem: missing, a folder, unreadable, larger than
    :data:`tdicam.files.MAX_TOML_BYTES` (an endless file such as ``/dev/zero``), not UTF-8
    text, invalid TOML. A UTF-8 byte-order mark (which some editors write) is accepted."""
    from tdicam.files import MAX_TOML_BYTES, input_path, read_bytes
    p = input_path(path, what)
    data = read_bytes(p, what, MAX_TOML_BYTES)
    try:
        return tomllib.loads(data.decode("utf-8-sig"))
    except RecursionError:
        raise TdicamError(f"{p}: invalid TOML: arrays or tables nested too deeply") from None
    except UnicodeDecodeError:
        raise TdicamError(f"{p}: not a TOML text file (it is not UTF-8)") from None
    except tomllib.TOMLDecodeError as exc:
        raise TdicamError(f"{p}: invalid TOML: {exc}") from None


def load_scene(path: str | Path | None = None, *, overrides: Mapping[str, Any] | None = None,
               labels: Mapping[str, str] | None = None, window: bool = True) -> Scene:
    """Read and validate a scene TOML file.

    Parameters
    ----------
    path : str or Path, optional
        The scene file. None starts from an empty scene (then ``overrides`` must give
        ``[orbit]`` or ``[turntable]``).
    overrides : mapping, optional
        ``{section: {key: value}}`` applied over the file before validation (used by the
        command line); a section or a key mapped to None is removed.
    labels : mapping, optional
        Error-message names for overridden keys, see :func:`scene_from_dict`.
    window : bool, optional
        Check the stage counts against ``M0``, see :func:`scene_from_dict`.

    Returns
    -------
    Scene

    Raises
    ------
    TdicamError
        The file is missing or not TOML, or any key is invalid (one line, naming the key).
    """
    data: dict = {}
    base_dir = None
    source = "<command line>"
    if path is not None:
        from tdicam.files import input_path
        p = input_path(path, "scene file")
        data = read_toml(p, "scene file")
        base_dir = p.resolve().parent
        source = str(p)
    if overrides is not None and not isinstance(overrides, Mapping):
        raise TdicamError(f"overrides: must be a mapping {{section: {{key: value}}}}, got "
                          f"{overrides!r}")
    if overrides:
        data = _merge(data, overrides)
    return scene_from_dict(data, base_dir=base_dir, source=source, labels=labels,
                           window=window)
