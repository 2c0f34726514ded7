"""tdicam's public Python API, re-exported by the package (``tdicam.simulate``, ...).

The functions here are what the command line calls: ``tdicam run`` is
``simulate(scene, ...).save(dir)``, ``tdicam plan`` is :func:`plan`, ``tdicam sweep`` is
:func:`sweep`, ``tdicam verilog`` is :func:`verilog`, ``tdicam sim`` is :func:`cosimulate`. Each is
a thin layer over a service (:mod:`tdicam.run`, :mod:`tdicam.planning`, :mod:`tdicam.sweeps`,
:mod:`tdicam.hw`, :mod:`tdicam.cosim`); errors in the input are one-line
:class:`~tdicam.errors.TdicamError` exceptions, as on the command line.

Layer: a service above the run, planning and sweep services; only the commands (and the
package's lazy names) import it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

from tdicam.errors import TdicamError, api_arguments, check_range
from tdicam.scene.examples import examples
from tdicam.scene.loader import Scene
from tdicam.version import __version__

if TYPE_CHECKING:                       # pragma: no cover - annotations only
    import xarray

__all__ = ["Scene", "Simulation", "simulate", "Plan", "plan", "sweep", "examples", "verilog",
           "cosimulate"]


# --------------------------------------------------------------------------------------
# simulate
# --------------------------------------------------------------------------------------


def _scene(scene: Scene | str | Path) -> Scene:
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, (str, Path)):
        return Scene.load(scene)
    raise TdicamError(f"scene: expected a Scene or a scene file's path, got "
                      f"{type(scene).__name__}")


@dataclass(eq=False)
class Simulation:
    """What :func:`simulate` computed: the images and measurements of a scene's sweep.

    The images and measurements are :attr:`dataset`; :meth:`save` writes the files.

    Attributes
    ----------
    scene : Scene
        The simulated scene (with the ``seed`` and ``lines`` given to :func:`simulate`).
    report : dict or None
        The report of the last :meth:`save` (``report.json``'s content), None before.
    """

    scene: Scene
    _run: Any = field(repr=False)
    report: dict | None = None
    _dataset: Any = field(default=None, repr=False)

    @property
    def dataset(self) -> xarray.Dataset:
        """The images and measurements as an :class:`xarray.Dataset` (built on first use)."""
        if self._dataset is None:
            self._dataset = _dataset(self.scene, self._run)
        return self._dataset

    def figures(self) -> list:
        """The run's figures as ``(file name, matplotlib Figure)`` pairs: what ``tdicam run``
        and :meth:`save` write as PNG (:func:`tdicam.run.figures.figures`: the crop on one
        relative scale, the normalised profile, the difference from the target, SNR vs
        stages on a flat target, the MTF on bars).

        Returns
        -------
        list of (str, matplotlib.figure.Figure)
        """
        from tdicam.run.figures import figures
        return list(figures(self.scene, self._run.rows, self._run.main))

    def save(self, out_dir: str | Path) -> dict:
        """Write exactly what ``tdicam run`` writes into ``out_dir``: the images, figures,
        ``report.json`` and ``report.md`` (docs/guide/run.md, "What tdicam run writes").

        With a ``[run.rtl]`` table (and ``rtl=True`` given to :func:`simulate`) the RTL
        co-simulation of the crop runs here. The files are staged and moved in at the end,
        so a failure leaves ``out_dir`` as it was; files an earlier run listed and this one
        does not write are removed, others are left alone.

        Parameters
        ----------
        out_dir : str or Path
            Output folder, created with its parents.

        Returns
        -------
        dict
            The report (``report.json``'s content); also kept as :attr:`report`.

        Raises
        ------
        TdicamError
            ``out_dir`` cannot be written (one line).
        """
        from tdicam.files import named
        from tdicam.run.runner import write_run
        self.report = write_run(self._run, named(out_dir, "out_dir"))
        return self.report


@api_arguments
def simulate(scene: Scene | str | Path, *, fidelity: str | None = None,
             lines: int | None = None, seed: int | None = None,
             force: tuple[str, ...] = (), impact: bool = True, rtl: bool = True,
             progress: bool = False, labels: Mapping[str, str] | None = None) -> Simulation:
    """Simulate a scene: every point of its sweep (``[tdi].stages`` x
    ``[motion].dv_over_v``), measured (SNR, MTF) next to the planning model's predictions.

    Parameters
    ----------
    scene : Scene, str or Path
        A scene, or a scene file's path.
    fidelity : {"exact", "fast", "auto"}, optional
        Overrides ``[run].fidelity``.
    lines : int, optional
        Output lines per point; overrides ``[run].lines`` (checked as it is).
    seed : int, optional
        Overrides ``[run].seed``: the same scene and seed give the same numbers.
    force : tuple of str
        Effects to run even where the scene does not need them (zero strength).
    impact : bool
        Measure each effect's impact (one crop run per effect).
    rtl : bool
        Co-simulate the ``[run.rtl]`` crop when the results are saved.
    progress : bool
        Show where the run is (:class:`tdicam.progress.Progress`: a bar on a terminal,
        stage lines on stderr otherwise), here and in :meth:`Simulation.save`.
    labels : mapping, optional
        Names of overridden scene keys in error messages (``{"run.lines": "--lines"}``:
        the command line's option names).

    Returns
    -------
    Simulation
        ``.dataset`` is an :class:`xarray.Dataset` with the images of the largest stage
        count (at the first dV/V) on dimensions ``line`` x ``pixel`` — ``target``
        (relative radiance 0..1), ``raw`` (one exposure, DN), ``single`` (that exposure
        after the pre-TDI blocks, DN), ``tdi`` (the camera output, DN) — and every
        measurement of every point on dimensions ``stages`` x ``dv_over_v``
        (``snr_gain_db``, ``mtf_measured``, ...: the keys of report.json's measurements,
        joined with ``_``, NaN where a point has none). Units are in each variable's
        ``units`` attribute; provenance (tdicam version, scene file, its settings, seed,
        fidelity) in the dataset's attributes. ``.save(dir)`` writes what ``tdicam run``
        writes.

    Raises
    ------
    TdicamError
        A bad scene or override, or a run that does not fit the memory (one line).
    """
    from tdicam.run.runner import simulate_scene
    sc = _scene(scene).with_run(lines=lines, seed=seed)
    if isinstance(force, str) or not isinstance(force, (tuple, list)):
        raise TdicamError(f"force must be a list of effect names, got {force!r}")
    if labels is not None and not isinstance(labels, Mapping):
        raise TdicamError(f"labels must be a mapping of scene keys to names, got {labels!r}")
    run = simulate_scene(sc, fidelity=fidelity, force=tuple(force), impact=impact, rtl=rtl,
                         progress=progress, labels=labels)
    return Simulation(sc, run)


def _dataset(scene: Scene, run) -> xarray.Dataset:
    import numpy as np
    import xarray as xr
    main, rows = run.main, run.rows
    stages, dvs = list(scene.tdi.stages), list(scene.motion.dv_over_v)
    dims = ("line", "pixel")
    shape = np.shape(main.output)
    data = {
        "target": (dims, np.asarray(main.target),
                   {"units": "1", "long_name": "ideal relative radiance at the output pixels"}),
        "raw": (dims, np.asarray(main.raw),
                {"units": "DN", "long_name": "one exposure of each ground line (sensor DN)",
                 "pedestal": float(main.pedestal_single)}),
        "single": (dims, np.asarray(main.single),
                   {"units": "DN", "long_name": "that exposure after the pre-TDI blocks",
                    "pedestal": float(main.pedestal_single)}),
        "tdi": (dims, np.asarray(main.output),
                {"units": "DN", "long_name": f"camera output (TDI, {main.stages} stages)",
                 "pedestal": float(main.pedestal_output),
                 "full_scale": int(main.output_full_scale)}),
    }
    flat = [_flatten(r) for r in rows]
    names = sorted({k for f in flat for k in f} - {"stages", "dv_over_v"})
    for name in names:
        grid = np.full((len(stages), len(dvs)), np.nan)
        for r, f in zip(rows, flat):
            if name in f:
                grid[stages.index(r["stages"]), dvs.index(r["dv_over_v"])] = f[name]
        data[name] = (("stages", "dv_over_v"), grid, {"units": _units(name)})
    coords = {"line": ("line", np.arange(shape[0]),
                       {"units": "line", "long_name": "output line (along track)"}),
              "pixel": ("pixel", np.arange(shape[1]),
                        {"units": "px", "long_name": "column (cross track)"}),
              "stages": ("stages", np.asarray(stages),
                         {"units": "1", "long_name": "TDI stages m"}),
              "dv_over_v": ("dv_over_v", np.asarray(dvs, np.float64),
                            {"units": "1", "long_name": "velocity mismatch dV/V"})}
    attrs = {"title": f"tdicam simulation of {Path(scene.source).stem}",
             "tdicam": __version__, "scene": str(scene.source),
             "scene_settings": json.dumps(scene.to_dict(), sort_keys=True),
             "seed": int(scene.run.seed), "lines": int(shape[0]),
             "fidelity_requested": run.fidelity or scene.run.fidelity,
             "fidelity": main.fidelity, "image_stages": int(main.stages),
             "image_dv_over_v": float(main.dv_over_v)}
    return xr.Dataset({k: xr.Variable(*v) for k, v in data.items()}, coords=coords,
                      attrs=attrs)


def _flatten(row: Mapping, prefix: str = "") -> dict:
    """The finite-or-NaN numbers of a measurement dict, keys joined with ``_``."""
    out = {}
    for k, v in row.items():
        name = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(_flatten(v, f"{name}_"))
        elif isinstance(v, bool):
            out[name] = float(v)
        elif isinstance(v, (int, float)) or type(v).__module__ == "numpy":
            try:
                out[name] = float(v)
            except (TypeError, ValueError):
                pass
        elif v is None:
            out[name] = float("nan")
    return out


def _units(name: str) -> str:
    for suffix, unit in (("_db", "dB"), ("_dn", "DN"), ("_per_s", "1/s"), ("seconds", "s"),
                         ("_cyc_per_px", "cycles/pixel"), ("_e", "electrons")):
        if name.endswith(suffix):
            return unit
    return "1"


# --------------------------------------------------------------------------------------
# plan
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Plan:
    """A planned camera (``tdicam plan``): every design point and the feasibility verdict.

    Attributes
    ----------
    feasible : bool
        False when a check of :attr:`design` says NO (listed in :attr:`infeasible`).
    infeasible : list of str
        The checks that say NO.
    design : dict
        The most demanding point (highest required frame rate): line period, frame rate,
        window, memory, DDR, gateware, SNR and MTF.
    points : list of dict
        One per GSD x stage count, as :attr:`design`.
    sensor : dict
        The sensor's columns, rows, bits, pitch, shutter and row timing.
    mode : str
        ``"orbit"`` or ``"turntable"``.
    platform : dict
        The orbit's altitude and ground speed, or the turntable's speed and distance.
    notes : list of str
        What the planner left out (stage counts the sensor does not allow, ...).
    scene : str or None
        The scene file planned from.
    """

    feasible: bool
    infeasible: list
    design: dict
    points: list
    sensor: dict
    mode: str
    platform: dict
    notes: list
    scene: str | None
    _report: dict = field(repr=False, compare=False)
    _scenes: list = field(repr=False, compare=False)

    def to_dict(self) -> dict:
        """The plan as ``tdicam plan --json`` prints it (a JSON-ready dict)."""
        return json.loads(json.dumps(self._report, default=_json_default))

    def text(self) -> str:
        """The report ``tdicam plan`` prints."""
        from tdicam.planning.sizing import report_text
        return report_text(self._report)

    def figures(self) -> list:
        """``(file name, matplotlib Figure)`` pairs: what ``tdicam plan --plot`` writes."""
        from tdicam.planning.sizing import figures
        return list(figures(self._report, self._scenes))


def _json_default(value):
    import numpy as np
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


@api_arguments
def plan(scene: Scene | str | Path | None = None, *, onchip_kbit: float | None = None,
         device: str | None = None, ddr_bits: int | None = None,
         ddr_clock_mhz: float | None = None, ddr_efficiency: float | None = None,
         fpga_clock_mhz: float | None = None, **options: Any) -> Plan:
    """Size a digital-TDI camera and say whether it works (``tdicam plan``).

    Parameters
    ----------
    scene : str, Path or Scene, optional
        A scene file (or a :class:`Scene` loaded from one, unchanged); ``options``
        override it. Without a scene and orbit options: Qu et al. 2010's
        example (600 km; GSD 5, 2, 1 m; 12/24/48/96 stages; 1280 x 1024 12-bit sensor).
    onchip_kbit : float, optional
        On-chip RAM for the partial sums, kbit (1 kbit = 1024 bit).
    device : str, optional
        FPGA part whose block RAM is the on-chip budget when ``onchip_kbit`` is not given.
    ddr_bits, ddr_clock_mhz, ddr_efficiency : optional
        DDR user interface: width (default 256), clock (default 100 MHz) and efficiency
        (default: the partial-sum access pattern's on the DRAM timing model).
    fpga_clock_mhz : float, optional
        Clock of the TDI gateware for every pixels-per-clock (default: the reference
        synthesis Fmax).
    **options
        Scene values by the names of ``tdicam plan``'s options (``altitude_km``,
        ``gsd_m``, ``stages``, ``columns``, ``rows``, ``bits``, ``signal_e``,
        ``dv_over_v``, ...); list-valued ones (``gsd_m``, ``stages``, ``dv_over_v``) take
        a sequence.

    Returns
    -------
    Plan

    Raises
    ------
    TdicamError
        A value out of its range or an unknown option (one line).
    """
    from tdicam.model.physics.plan import DDR_USER_CLOCK_HZ, DDR_WORD_BITS, onchip_budget
    from tdicam.planning import sizing
    known = {dest for dest, *_ in sizing.SCENE_OPTIONS}
    for name in options:
        if name not in known:
            raise TdicamError(f"plan: unknown option {name!r}; valid: "
                              + ", ".join(sorted(known)))
    values = sizing.check_options({"onchip_kbit": onchip_kbit, "ddr_bits": ddr_bits,
                                   "ddr_clock_mhz": ddr_clock_mhz,
                                   "ddr_efficiency": ddr_efficiency,
                                   "fpga_clock_mhz": fpga_clock_mhz, "device": device})
    if values["onchip_kbit"] is not None:
        budget = int(round(values["onchip_kbit"] * 1024))
    elif device is not None:
        budget = onchip_budget(device)
    else:
        budget = None
    given = {k: v for k, v in options.items() if v is not None}
    if isinstance(scene, Scene):
        # the planner reads a file (options override it): a Scene is planned from its own
        # file when it is what the file gives, never from a file it differs from
        if scene.source.startswith("<") or Scene.load(scene.source) != scene:
            raise TdicamError("plan: scene: this Scene is not its scene file's content (made "
                              "in Python or loaded with overrides): write it to a file and "
                              "plan that, or give the changes as plan's options")
        scene = scene.source
    elif scene is not None and not isinstance(scene, (str, Path)):
        raise TdicamError(f"plan: scene: expected a scene file's name or a Scene, got "
                          f"{type(scene).__name__}")
    scenes, labels = sizing.plan_scenes(None if scene is None else str(scene), given)
    ddr_bits = DDR_WORD_BITS if values["ddr_bits"] is None else values["ddr_bits"]
    ddr_hz = DDR_USER_CLOCK_HZ if ddr_clock_mhz is None else values["ddr_clock_mhz"] * 1e6
    rep = sizing.plan_report(scenes, onchip_budget_bits=budget, ddr_bits=ddr_bits,
                             ddr_clock_hz=ddr_hz, ddr_efficiency=values["ddr_efficiency"],
                             fpga_clock_mhz=values["fpga_clock_mhz"],
                             notes=labels.get("notes", ()))
    return Plan(feasible=rep["feasible"], infeasible=list(rep["infeasible"]),
                design=rep["design"], points=rep["points"], sensor=rep["sensor"],
                mode=rep["mode"], platform=rep.get("orbit", rep.get("turntable")),
                notes=list(rep["notes"]), scene=rep["scene"], _report=rep,
                _scenes=list(scenes))


# --------------------------------------------------------------------------------------
# sweep
# --------------------------------------------------------------------------------------


@api_arguments
def sweep(source: str | Path | Mapping[str, Any], out_dir: str | Path | None = None, *,
          workers: int | None = None, scheduler: str | None = None, serial: bool = False,
          impact: bool = False, force: bool = False, limit: int | None = None,
          connect_timeout: float = 10.0, progress: bool = False) -> xarray.Dataset:
    """Run a trade study (``tdicam sweep``) and return its labelled dataset.

    Parameters
    ----------
    source : str, Path or mapping
        A sweep TOML file, or the same content as a dict (its ``scene`` relative to the
        current folder, its name ``sweep`` unless it gives one).
    out_dir : str or Path, optional
        Results folder (the store a rerun resumes from, and every file ``tdicam sweep``
        writes); default ``out/sweeps/<name>``.
    workers : int, optional
        Processes of the local Dask cluster (default: the CPU count).
    scheduler : str, optional
        Address of a running Dask scheduler instead of a local cluster.
    serial : bool
        Run every point in this process, in order.
    impact : bool
        Measure each effect's impact in every run.
    force : bool
        Accept more runs (points x repeats) than the safety limit.
    limit : int, optional
        Compute at most this many runs (>= 0), and validate only the points they need
        (plus every value of every axis once); a rerun into the same ``out_dir`` finishes
        the sweep. The dataset holds NaN (status ``missing``) where a run is missing.
    connect_timeout : float
        Seconds to wait for ``scheduler``, in (0, 3600].
    progress : bool
        Show a progress bar on a terminal.

    Returns
    -------
    xarray.Dataset
        What ``sweep.nc`` holds: one dimension per axis (``zip`` for a zip group) and
        ``repeat``, the result columns as variables, provenance in the attributes. Two
        attributes are added in memory: ``attrs["failed"]`` counts the runs that failed,
        ``attrs["summary"]`` is the text ``tdicam sweep`` prints.

    Raises
    ------
    TdicamError
        A bad sweep file, parameter or output folder, an unreachable scheduler (one line).
    KeyboardInterrupt
        Re-raised with the attribute ``out_dir``: the finished runs are kept there, and the
        same call finishes the sweep.
    """
    import xarray as xr
    from tdicam.files import named
    from tdicam.sweeps.runner import finished_in, read_sweep, run_sweep, validate_sweep
    check_range("--connect-timeout", connect_timeout, 0, 3600, integer=False, lo_open=True)
    if limit is not None:                   # before the points are expanded
        check_range("--limit", limit, 0, None)
    sw = read_sweep(source, force=force, impact=impact)
    out = named(out_dir, "out_dir") if out_dir is not None else Path("out") / "sweeps" / sw.name
    # with a limit, only the points its runs need are validated (and each axis value once)
    sw = validate_sweep(sw, progress=progress, limit=limit,
                        finished=finished_in(out) if limit is not None else None)
    try:
        res = run_sweep(sw, out, workers=workers, scheduler=scheduler, serial=serial,
                        limit=limit, progress=progress, connect_timeout=connect_timeout)
    except KeyboardInterrupt as stop:
        stop.out_dir = out
        raise
    with xr.open_dataset(res.out_dir / "sweep.nc", engine="h5netcdf") as ds:
        data = ds.load()
    data.attrs["failed"] = len(res.failed)
    data.attrs["summary"] = res.summary()
    return data


# --------------------------------------------------------------------------------------
# a block's Verilog and co-simulation (the registry, tdicam.blocks, is below these tools)
# --------------------------------------------------------------------------------------


@api_arguments
def verilog(block: str, **params: Any) -> str:
    """A block's Verilog, as ``tdicam verilog NAME --PARAM V ...`` writes it.

    Parameters
    ----------
    block : str or tdicam.blocks.Block
        The block's name (:func:`tdicam.blocks.names`) or its registry entry.
    **params
        Block parameters by name (``tdicam.blocks.get(NAME).describe()`` lists them); the
        others at their defaults.

    Returns
    -------
    str
        Deterministic Verilog text: a header naming the tdicam version, the block and its
        parameters, then the top module, named after the block.

    Raises
    ------
    TdicamError
        An unknown block or parameter, or a value out of its range (one line).
    """
    from tdicam.hw.verilog import generate
    return generate(block, params)


@api_arguments
def cosimulate(block: str, arrays: dict | None = None, *, sim: str = "icarus", mode: str = "fast",
          idle: float = 0.2, backpressure: float = 0.2, seed: int = 1,
          cases: list[str] | None = None, wave_dir: str | None = None,
          on_case: Any = None, **params: Any) -> list[dict]:
    """Co-simulate a block's Verilog against its golden model (cocotb).

    Parameters
    ----------
    block : str or tdicam.blocks.Block
        The block's name or its registry entry.
    arrays : dict of str to ndarray, optional
        Scene arrays as the block's ``golden_model`` takes them. None: every stored golden
        case (what ``tdicam sim NAME`` runs; ``mode="beat"`` skips the ``fast-only`` ones).
    sim : {"icarus", "verilator"}
        The simulator.
    mode : {"fast", "beat"}
        HDL-side stimulus and stalls, or per-beat cocotb.
    idle, backpressure : float
        Probabilities of an idle input cycle and of ``tready`` low, in [0, 1).
    seed : int
        Seed of the idle and backpressure pattern.
    cases : list of str, optional
        Only these golden cases (without ``arrays``; ``tdicam sim --case``).
    wave_dir : str, optional
        Where the waveform (FST) around a case's first mismatch is written (default: the
        build folder's ``waves``); the row's ``waveform`` and ``message`` name it.
    on_case : callable(dict), optional
        Called with each row as soon as its case has run (``tdicam sim`` prints it).
    **params
        Block parameters (with ``arrays`` only; a golden case has its own).

    Returns
    -------
    list of dict
        One row per case (``case``, ``pixels``, ``mismatches``, ``cycles``, ``wall_s``,
        ...); with ``arrays``, one row whose ``out`` is the simulated output as the block's
        ``golden_model`` gives it (None on a mismatch).

    Raises
    ------
    TdicamError
        An unknown block, a block without a stream co-simulation, a bad parameter, a
        simulator missing.
    """
    from tdicam import blocks
    from tdicam.cosim.cases import run_cases
    from tdicam.cosim.run import run_scene
    blk = blocks.get(block) if isinstance(block, str) else block
    kw = dict(sim=sim, mode=mode, idle=idle, backpressure=backpressure, seed=seed,
              wave_dir=wave_dir)
    if arrays is None:
        if params:
            raise TdicamError(f"block {blk.name}: parameters go with arrays (each golden "
                              f"case has its own)")
        return run_cases(blk.name, cases=cases, report=on_case or (lambda row: None), **kw)
    if cases:
        raise TdicamError(f"block {blk.name}: cases= selects golden cases; it does not go "
                          f"with arrays")
    run, out = run_scene(blk, arrays, params, **kw)
    row = {"case": "arrays", **run.row(), "out": out}
    if on_case is not None:
        on_case(row)
    return [row]
