"""Scene files: the reader shared by ``tdicam plan`` and the scene simulator.

A scene is a TOML file (read with :mod:`tomllib`) that describes the platform motion, the
target and its light level, the sensor, TDI, motion errors, the processing pipeline and how
to run the simulation; :mod:`tdicam.scene.schema` states every section, key, default and
range. :func:`load_scene` validates a file completely and returns a frozen :class:`Scene`;
every error is one line that names the offending key, e.g. ``[sensor].read_noise_e: must be
>= 0, got -1``. Unknown sections and keys are errors, with a did-you-mean hint when a valid
name is close. The validating reader of each section, beside the meaning of its keys, is in
:mod:`tdicam.scene.sections`; this module holds the :class:`Scene`, the cross-section checks
(stages against the window limit, the line period, the output's extent) and the entry points.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from tdicam import blocks
from tdicam.blocks import steps as _steps
from tdicam.errors import TdicamError, api_arguments, check_choice, check_range
from tdicam.scene import sections
from tdicam.scene.keys import check_key, set_key
from tdicam.scene.reading import Section, hint
from tdicam.model.physics.camera import Camera
from tdicam.model.physics import plan as _plan
from tdicam.scene.schema import (BLOCKS, BOUNDS, BUNDLED_IMAGES, FIDELITIES, TARGET_KINDS, Ddr,
                                 Motion, Optics, Orbit, Pipeline, RtlRun, Run, Sensor,
                                 TargetSpec, Tdi, Turntable)

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
        if d["pipeline"]["output"] == "stream":     # the pixel stream out: as before
            del d["pipeline"]["output"]
        if d["camera"] is None:             # no camera budget: the dict of before
            del d["camera"]
        if d["run"]["figure_crop"] is None:     # a centred crop: the dict of before
            del d["run"]["figure_crop"]
        if d.get("ddr") is not None:        # the model's stall pattern, as given
            stalls = d["ddr"].pop("stalls")
            d["ddr"].update({k: v for k, v in stalls})
        return d




def _check_stages(sec: Section, scene: Scene, window: bool = True) -> None:
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


def _check_digital_tdi(tdi_sec: Section, sensor_sec: Section, scene: Scene) -> None:
    for m in scene.tdi.stages:
        why = digital_tdi_limits_error(scene, m)
        if why is not None:
            key, _, msg = why.partition(": ")
            (tdi_sec if key == "stages" else sensor_sec).fail(key, msg)


def _check_output(sec: Section, scene: Scene) -> None:
    """``[pipeline].output = "links"``: the links are those of ``[camera]``, which must be
    given, its frame rates a whole ratio (one frame sent in K)."""
    if scene.pipeline.output != "links":
        return
    if scene.camera is None:
        sec.fail("output", "'links' sends the chain on the output links of [camera] (links, "
                           "link_clock_mhz, link_pixel_bits, output_frame_rate_hz): give a "
                           "[camera] section, or output = 'stream'")
    from tdicam.model.frame_select import keep_every
    keep_every(scene.camera.frame_rate_hz, scene.camera.output_frame_rate_hz)


def _check_chain(sec: Section, scene: Scene, labels) -> None:
    """What the scene simulator would refuse after its work, refused here: a memory the
    scene places in DDR without a ``[ddr]`` section, TDI output too wide for median3 after
    it, more front-end lanes than the front takes (both gains with a merging block)."""
    from tdicam.blocks.lvds import MAX_LANES
    from tdicam.blocks.median3 import check_after_tdi
    names = list(scene.pipeline.blocks)
    for b in names:
        mem = blocks.get(b).pipeline.memory
        if mem.placement is not None and scene.ddr is None and mem.placement(scene) == "ddr":
            raise TdicamError(f"{labels.get(f'pipeline.{b}.memory', f'[pipeline.{b}].memory')} "
                              f"= 'ddr' keeps its {mem.holds} in DDR, but the scene has no "
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
            raise TdicamError(f"[{name}]: unknown section" + hint(name, _SECTIONS))
    if ("orbit" in data) == ("turntable" in data):
        which = "both" if "orbit" in data else "neither"
        raise TdicamError(f"{labels.get('orbit', '[orbit]')}: a scene needs exactly one of "
                          f"[orbit] and [turntable], got {which}")
    base = Path.cwd() if base_dir is None else Path(base_dir)

    def section(name):
        return Section(name, data.get(name), labels)

    orbit = sections.read_orbit(section("orbit")) if "orbit" in data else None
    turntable = sections.read_turntable(section("turntable")) if "turntable" in data else None
    target = sections.read_target(section("target"), base)
    sensor = sections.read_sensor(section("sensor"))
    optics = sections.read_optics(section("optics"))
    tdi_sec = section("tdi")
    tdi = sections.read_tdi(tdi_sec, sensor)
    motion = sections.read_motion(section("motion"))
    pipeline = sections.read_pipeline(section("pipeline"), sensor, labels)
    run = sections.read_run(section("run"), sensor, labels)
    ddr = sections.read_ddr(section("ddr")) if "ddr" in data else None
    cam = sections.read_camera(section("camera"), sensor) if "camera" in data else None
    scene = Scene(orbit=orbit, turntable=turntable, target=target, sensor=sensor, tdi=tdi,
                  motion=motion, pipeline=pipeline, run=run, source=source, optics=optics,
                  ddr=ddr, camera=cam)
    # what it was read from, for Scene.replace (not a field: not compared, not in to_dict)
    object.__setattr__(scene, "_input", (copy.deepcopy(dict(data)), base_dir, window))
    _check_stages(tdi_sec, scene, window)
    _check_digital_tdi(tdi_sec, section("sensor"), scene)
    _check_chain(section("pipeline"), scene, labels)
    _check_output(section("pipeline"), scene)
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


def _check_line_period(sec: Section, scene: Scene) -> None:
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


def _check_extent(target_sec: Section, run_sec: Section, scene: Scene) -> None:
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
