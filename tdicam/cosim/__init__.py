"""Co-simulation of generated Verilog with cocotb on Icarus Verilog or Verilator.

:func:`run_stream` builds (once per block, parameter set and simulator; cached on disk
under ``build/cosim``) a testbench around a stream block's Verilog top and runs the
cocotb test module ``stream_tb`` (:mod:`tdicam.simtb.stream_tb`) in one of two drive modes:

``beat``
    cocotb drives and samples the AXI4-Stream ports every cycle, with random idle cycles
    and backpressure. Slow; for protocol tests.
``fast``
    the stimulus sits in an HDL memory, the clock and the random idle/backpressure are in
    HDL, every output transfer is written to a file by the simulator; cocotb awaits once.

Both return the output transfers as :class:`~tdicam.beats.Beats` for comparison
against the golden model with :func:`compare`.

Layer: the simulation tools (drivers of Icarus, Verilator and the Amaranth simulator, the
idle/backpressure generator, the golden-vector store, the LiteDRAM replay). May import
:mod:`tdicam.hw` (Verilog generation, the simulators' setup), the blocks' registry and
everything below; imported by the camera, the services and the commands.
"""

from tdicam.hw.tools import SIMULATORS, tool_env
from tdicam.cosim.build import (BUILD_NOTICE_S, BUILD_ROOT, WAVE_DIR, build_dir_for,
                                build_sources, check_build_root, run_cocotb, run_standalone)
from tdicam.cosim.compare import Comparison, compare, locate
from tdicam.cosim.stream import MODES, SimResult, run_stream, stream_ports
from tdicam.cosim.run import (AMARANTH, WAVE_WINDOW, CaseRun, keep_wave, run_beats, run_case,
                              run_golden_case, run_scene, wave_window, waveform)

__all__ = ["SIMULATORS", "MODES", "BUILD_ROOT", "BUILD_NOTICE_S", "AMARANTH", "WAVE_DIR", "WAVE_WINDOW", "wave_window",
           "keep_wave", "SimResult", "Comparison", "CaseRun", "run_stream", "compare", "locate",
           "run_beats", "waveform", "run_case", "run_scene", "run_golden_case",
           "build_dir_for", "check_build_root", "tool_env", "stream_ports", "build_sources",
           "run_cocotb", "run_standalone"]
