"""``tdicam plan``: size a digital-TDI camera from the orbit (or turntable) and the sensor.

Prints Qu et al. 2010's Table 2 (line period and minimum frame rate per GSD and stage count) and a
feasibility report for the most demanding point of the table (highest required frame rate):
required vs available frame rate, the rolling-shutter window (n_lines, M0, back porch),
partial-sum width and line-buffer memory of the basic and optimized structures, the DDR
bandwidth the partial sums would need in external memory vs the interface, what the TDI
gateware must do (pixel rate, pixels per clock, clock) and whether the measured synthesis
(the synthesis record: the TDI block per pixels-per-clock, and the scene's whole chain when it
was placed and routed with ``tdicam synth pipeline --record``) does it, the expected SNR gain (digital and charge domain) and the MTF at Nyquist (the camera
model the scene simulator renders, and the paper's model of Yuan et al. 2013 beside it); for a
scene with a ``[camera]`` section, the whole camera's rate budget (lanes, processing clock,
DDR traffic, NAND load, output links, the frame rate each carries and the part that limits
it). Parameters
come from a scene file (``--scene``), from options, or both (options override the file).
``--json`` prints the same numbers for scripts; ``--plot DIR`` writes three PNG figures.

Without a scene or orbit options the command plans Qu et al. 2010's example: 600 km, GSD 5, 2 and
1 m, 12/24/48/96 stages on a 1280 x 1024 12-bit sensor; without ``--stages`` the stage counts
the sensor's rows or window ``M0`` do not allow are left out (the report says which). Stage
counts given above ``M0`` are planned: the window check says NO (exit status 1).

The work is done by :func:`tdicam.api.plan` (:mod:`tdicam.planning.sizing`); this module
parses arguments.
"""

from __future__ import annotations

import json
import os
import re
import sys
from pathlib import Path

from tdicam.api import plan
from tdicam.planning import sizing
from tdicam.commands._parsing import add_source, source_path
from tdicam.errors import valid_range
from tdicam.files import check_dir, open_output
from tdicam.model.physics.plan import DDR_USER_CLOCK_HZ, DDR_WORD_BITS, ONCHIP_RAM_BITS

__all__ = ["register", "run"]

_EPILOG = (f"exit status: 0 when the plan is feasible (or a check is unknown), "
           f"{sizing.EXIT_INFEASIBLE} when its feasibility report says NO (frame rate, "
           f"window, DDR bandwidth of spilled partial sums, the sensor's LVDS lanes' bit rate, "
           f"gateware pixel rate, or a scene pipeline the gateware cannot build), 2 for bad "
           f"input. Reference TDI Fmax (MHz by ppc): "
           + ", ".join(f"ppc {k}: {v:g}" for k, v in sizing.REFERENCE_TDI_FMAX_MHZ.items()))

#: The valid range of each of the plan's own options, as its errors print it.
_VALID = {opt: valid_range(lo, hi, lo_open=lo_open)
          for _, opt, lo, hi, _, lo_open in sizing.PLAN_OPTIONS}

# argparse reads "-1e-12" as an option: accept every float literal as a (negative) number
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")


def register(subparsers) -> None:
    """Add the ``plan`` subcommand to an argparse ``subparsers`` object."""
    p = subparsers.add_parser(
        "plan", help="size a digital-TDI camera: line/frame rate, window, memory, gateware, "
                     "SNR, MTF",
        description=" ".join(__doc__.split("\n\n")[:2]).replace("``", ""), epilog=_EPILOG)
    p._negative_number_matcher = _NEGATIVE_NUMBER
    add_source(p, flag="--scene", required=False,
               help="scene TOML file (options override it; every key: 'tdicam scenes "
                    "--reference')")
    metavars = {int: "N", float: "X", str: "NAME"}
    for dest, sec, key, opt, typ, nargs, text in sizing.SCENE_OPTIONS:
        p.add_argument(opt, dest=dest, type=typ, nargs=nargs, default=None,
                       metavar=metavars[typ], help=text + sizing.bounds_text(sec, key))
    p.add_argument("--onchip-kbit", type=float, default=None, metavar="X",
                   help="on-chip RAM available for the partial sums, kbit (1 kbit = 1024 bit; "
                        "the report's kbit/Mbit are binary too; valid "
                        + _VALID["--onchip-kbit"] + ")")
    p.add_argument("--device", default=None, metavar="NAME",
                   help="FPGA part whose block RAM is the on-chip budget when --onchip-kbit "
                        "is not given: " + ", ".join(ONCHIP_RAM_BITS))
    p.add_argument("--ddr-bits", type=int, default=DDR_WORD_BITS, metavar="N",
                   help="DDR user-interface width in bits, at least one partial sum "
                        "(default 256; valid up to " + _VALID["--ddr-bits"].split("..")[1]
                        + ")")
    p.add_argument("--ddr-clock-mhz", type=float, default=DDR_USER_CLOCK_HZ / 1e6, metavar="X",
                   help="DDR user-interface clock in MHz (default 100; valid "
                        + _VALID["--ddr-clock-mhz"] + ")")
    p.add_argument("--ddr-efficiency", type=float, default=None, metavar="X",
                   help="DDR interface efficiency in (0, 1] (default: the partial-sum access "
                        "pattern's on the DRAM timing model, per design point)")
    p.add_argument("--fpga-clock-mhz", type=float, default=None, metavar="X",
                   help="clock of the TDI gateware in MHz, for every pixels-per-clock "
                        "(default: the synthesis record's Fmax; valid "
                        + _VALID["--fpga-clock-mhz"] + ")")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.add_argument("--plot", metavar="DIR", help="write PNG figures into DIR")
    p.set_defaults(func=run)


def _write_figures(the_plan, out) -> list[Path]:
    files = []
    for name, fig in the_plan.figures():
        files.append(out / name)
        with open_output(files[-1]) as fh:
            fig.savefig(fh, dpi=100, format="png")
    return files


def _emit(text) -> None:
    """Print ``text``; a reader that closed the pipe (``| head``) is not an error."""
    try:
        sys.stdout.write(text + "\n")
        sys.stdout.flush()
    except BrokenPipeError:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())   # so the interpreter's final flush is quiet


def run(args) -> int:
    """Run ``tdicam plan`` for parsed arguments; returns the exit code (see the epilog)."""
    given = {dest: getattr(args, dest) for dest, *_ in sizing.SCENE_OPTIONS
             if getattr(args, dest, None) is not None}
    the_plan = plan(source_path(args), onchip_kbit=args.onchip_kbit, device=args.device,
                    ddr_bits=args.ddr_bits, ddr_clock_mhz=args.ddr_clock_mhz,
                    ddr_efficiency=args.ddr_efficiency, fpga_clock_mhz=args.fpga_clock_mhz,
                    **given)
    rep = the_plan.to_dict()
    # the folder is made once the plan is computed: a refused plan leaves nothing behind
    plot_dir = None if args.plot is None else check_dir(args.plot, "--plot")
    if plot_dir is not None:
        rep["plots"] = [str(f) for f in _write_figures(the_plan, plot_dir)]
    if args.json:
        _emit(json.dumps(rep, indent=2, allow_nan=False))
    else:
        text = the_plan.text()
        if plot_dir is not None:
            text += "\n\nwrote " + ", ".join(rep["plots"])
        _emit(text)
    return 0 if the_plan.feasible else sizing.EXIT_INFEASIBLE

