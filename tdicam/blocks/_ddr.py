"""What the DDR blocks (``ddr``, ``cds_ddr``, ``tdi_ddr``) share: the simulation
controller's stall-pattern parameters and the simulation top around a DDR user core.

Each DDR block's Verilog top is its user logic with the simulation-only controller model
:class:`~tdicam.hdl.simmodels.mig_model.MigModel` behind it (:class:`~tdicam.hdl.simmodels.mig_model.SimTop`), so the fast
co-simulation runs the whole round trip in the simulator; the stall pattern is a parameter
set (default :data:`tdicam.model.dram.DEFAULT_STALLS`: latency 20..60, refresh 44 of every 780
cycles, each ready dropped with probability 16/256), on top of the DRAM timing
(:class:`tdicam.model.dram.DramTiming`: turnarounds, row activates, cycle-equal with
:class:`tdicam.model.dram.MigSim` with ``dram=``), so the everyday co-simulation charges what
the block's order of accesses costs on DDR3. ``ddr_error`` (the model's sticky
error) blocks the input, so a bad access shows as a stalled run.
"""

from tdicam.errors import TdicamError
from tdicam.model.ddr import ADDR_BITS, ADDR_PER_WORD, CAPACITY_BYTES, WORD_BITS
from tdicam.model.dram import DEFAULT_STALLS, _check_stalls
from tdicam.blocks import Param

__all__ = ["STALL_PARAMS", "address_params", "stalls_of", "check_stalls", "sim_top",
           "check_base"]

STALL_PARAMS = (
    Param("lat_lo", DEFAULT_STALLS["lat_lo"], "model: shortest read latency, cycles", lo=2,
          hi=1000),
    Param("lat_hi", DEFAULT_STALLS["lat_hi"], "model: longest read latency, cycles", lo=2,
          hi=1000),
    Param("refresh_period", DEFAULT_STALLS["refresh_period"],
          "model: cycles between refresh starts", lo=1, hi=1 << 20),
    Param("refresh_cycles", DEFAULT_STALLS["refresh_cycles"],
          "model: cycles of each refresh (app_rdy low)", lo=0, hi=1 << 20),
    Param("drop", DEFAULT_STALLS["drop"],
          "model: each ready dropped with probability drop/256 per cycle", lo=0, hi=255),
    Param("seed", DEFAULT_STALLS["seed"], "model: stall pattern seed (each its own pattern)", lo=1,
          hi=0xFFFFFFFF),
)
_STALL_NAMES = tuple(p.name for p in STALL_PARAMS)


def address_params(base_help):
    """The ``line_stride``, ``base`` and ``capacity_mib`` parameters of a DDR buffer."""
    return (
        Param("line_stride", None, "address units between lines (8 per word); default "
                                   "the line rounded up to a power of two", lo=8,
              hi=1 << 28),
        Param("base", 0, base_help, lo=0, hi=(1 << 28) - 8),
        Param("capacity_mib", 1024, "DDR size for the address check, MiB", lo=1, hi=1024),
    )


def stalls_of(p):
    """The stall-pattern parameters of a resolved parameter dict."""
    return {k: p[k] for k in _STALL_NAMES}


def check_stalls(p):
    """Check the stall-pattern parameters of a resolved parameter dict."""
    _check_stalls(*(p[k] for k in _STALL_NAMES))


def sim_top(core, words, stalls):
    """:class:`~tdicam.hdl.interfaces.axis.AxisTop` of ``core`` with the MIG model of ``words`` words
    and the stall pattern ``stalls`` behind it."""
    from tdicam.hdl.interfaces.axis import AxisTop
    from tdicam.hdl.simmodels.mig_model import SimTop
    return AxisTop(SimTop(core, depth_words=max(1, words), **stalls))


def check_base(base, need, what, capacity_bytes=CAPACITY_BYTES):
    """A scene's DDR buffer of ``need`` address units fits above ``[ddr].base``: else a
    one-line :class:`~tdicam.errors.TdicamError` naming the key, what the buffer is and the
    highest base that fits (before the block's own address check, which knows no scene
    key)."""
    top = min(capacity_bytes * 8 // (WORD_BITS // ADDR_PER_WORD), 1 << ADDR_BITS)
    if base + need > top:
        raise TdicamError(f"[ddr].base = {base}: the {what} needs {need} address units "
                          f"above it and the memory has {top}: give [ddr].base <= "
                          f"{max(top - need, 0) // 8 * 8}")
