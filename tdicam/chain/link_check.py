"""The co-simulation of a top that ends in the camera's output links
(``[pipeline].output = "links"``): the stream testbench's capture of the links' words
(:func:`capture_testbench`) and the golden words as the testbench sees them
(:func:`golden_beats`, :func:`kept_images`), for :mod:`tdicam.chain.cosim`. The lanes'
testbench captures them itself (:mod:`tdicam.simtb.system_lanes_tb`)."""

import numpy as np

from tdicam.errors import TdicamError

__all__ = ["PADDED", "capture_testbench", "golden_beats", "kept_images"]

#: Bits of a link word in the output file of a top with the output links (the 18-bit word
#: ``TXD | TKLSB << 16 | TKMSB << 17`` zero-padded to whole bytes).
PADDED = 24


def capture_testbench(tb, n):
    """The testbench of a top that ends in ``n`` output links: the link clock ``link_clk``
    at half the processing clock (a register toggled on every ``clk`` edge: the whole
    camera's 100 MHz links beside its 200 MHz blocks), ``link_rst`` the reset, and in
    place of ``m_axis`` the links' words: every link clock on which link 0 sends a word
    other than IDLE (the links send their IDLEs together, in lockstep) is one output beat
    of every link's word (element ``L`` link ``L``'s), written to ``out.hex`` as an output
    beat would be; the run ends ``drain`` cycles after the last such word."""
    from tdicam.hdl.tlk2711 import pin_names
    from tdicam.model.tlk2711 import IDLE
    old = "".join(f"    .m_axis_{s}(m_{s}){',' if s != 'tlast' else ''}\n"
                  for s in ("tdata", "tvalid", "tready", "tuser", "tlast"))
    if old not in tb:
        raise TdicamError("pipeline: the fast-mode testbench changed shape; update "
                          "tdicam.chain.link_check.capture_testbench")
    words = [f"{{l{k}_tkmsb, l{k}_tklsb, l{k}_txd}}" for k in range(n)]
    pins = ",\n".join(f"    .{p}({q})" for k in range(n) for p, q in zip(
        pin_names(k), (f"l{k}_txd", f"l{k}_tklsb", f"l{k}_tkmsb")))
    tb = tb.replace(old, "    .link_clk(link_clk),\n    .link_rst(rst),\n" + pins + "\n")
    padded = ", ".join(f"{PADDED - 18}'d0, {w}" for w in reversed(words))
    decl = ["  reg link_clk = 1'b0;", "  always @(posedge clk) link_clk <= ~link_clk;"]
    decl += [f"  wire [15:0] l{k}_txd;\n  wire l{k}_tklsb, l{k}_tkmsb;" for k in range(n)]
    decl += [f"  assign m_tvalid = link_clk && {words[0]} != 18'h{IDLE:05x};",
             f"  assign m_tdata = {{{padded}}};",
             "  assign m_tuser = 1'b0;", "  assign m_tlast = 1'b0;", ""]
    marker = "  pipeline dut (\n"
    return tb.replace(marker, "\n".join(decl) + "\n" + marker, 1)


def golden_beats(words):
    """The golden link words ``(links, n)`` as the testbench captures them: one beat a word
    slot that is not IDLE (the links send their IDLEs together), every link's word in it."""
    from tdicam.beats import Beats
    from tdicam.model.tlk2711 import IDLE
    w = words[:, words[0] != IDLE].T.astype(np.uint64)
    z = np.zeros(len(w), bool)
    return Beats(w, z, z.copy())


def kept_images(p, gold):
    """The images the links of plan ``p`` carry of the golden chain's output."""
    from tdicam.model.frame_select import link_images
    return link_images(gold[-1][2], image_rows=p.links.image_rows, keep=p.links.keep)
