"""The simulator environment (:func:`tdicam.hw.tools.tool_env`)."""

import shutil

import pytest

from tdicam.errors import TdicamError
from tdicam.hw import tools


@pytest.mark.parametrize("have_ccache", [True, False])
def test_verilator_builds_share_runtime_objects_through_ccache(monkeypatch, have_ccache):
    """With ccache on PATH a Verilator build compiles through it (verilated.mk's OBJCACHE),
    so the runtime objects every build compiles alike are reused; without it, nothing is
    set; a user's own OBJCACHE is kept."""
    real = shutil.which
    monkeypatch.setattr(tools.shutil, "which",
                        lambda n: (("/usr/bin/ccache" if have_ccache else None)
                                   if n == "ccache" else real(n)))
    monkeypatch.delenv("OBJCACHE", raising=False)
    tools.tool_env("verilator")
    assert tools.os.environ.get("OBJCACHE") == ("ccache" if have_ccache else None)
    monkeypatch.setenv("OBJCACHE", "sccache")
    tools.tool_env("verilator")
    assert tools.os.environ["OBJCACHE"] == "sccache"


def test_unknown_simulator_is_one_line():
    with pytest.raises(TdicamError, match="unknown simulator 'xsim'; valid: "):
        tools.tool_env("xsim")
