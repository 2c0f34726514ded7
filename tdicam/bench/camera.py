"""The whole camera of Ning et al. 2019 at full width, co-simulated and timed.

A cut of ``scenes/ning2019_gmax0504_full.toml`` (all 5144 columns, both gains, the scene's
chain lvds -> cds_ddr -> nuc_ddr -> hdr -> tdi -> median3 at the camera plan's pixels per
clock) runs through the generated top on Verilator with cocotb (:func:`camera_cut`,
:func:`camera_run`): at power-up each gain channel's NAND model is scanned and its
coefficient image written to the channel's DDR model, then every line the reset line is
written to DDR, the signal line read beside the reset line and the coefficients read back,
both users behind the channel's DdrArbiter; every block's output (tap) is compared bit for
bit with the golden chain. The scene is an area camera (one stage): tdicam's frame is one
line, so a cut of ``lines`` lines is ``lines`` reset frames and ``lines`` signal frames of a
line each a gain (the frame pair's first ``lines`` rows). Its NUC is per pixel
(``[pipeline.nuc].coefficients = "frame"``): the coefficient image has a line per row of the
cut (``lines`` x columns, each row its own gain and offset), loaded from the NAND model into
DDR, and row ``r`` is read against coefficient line ``r`` (nuc_ddr's ``image_rows``), in
the gateware and in the golden chain.
The top's input is the sensor's lanes (the scene's ``[sensor.lvds]``: 40 lanes a gain, 80
in all, 12-bit words at 300 Mbit/s): the cut's reset and signal lines are sent on them by
the chain's own lane model (:func:`tdicam.cosim.lvds_front.plan_case`: the lanes' training,
then each line as sync, header and 129 pixel words a lane, lanes 24..39 a padded last
slot), the word clock at 25 MHz beside the processing clock at ``[camera].clock_mhz`` (200
MHz: a line's 643 beats in its 131 word clocks need >= 122.7 MHz,
:func:`tdicam.model.lvds_front.min_proc_mhz`), as the system lanes co-simulation runs
(:func:`tdicam.chain.cosim.run_top`). A narrower cut takes fewer lanes
(``lanes_per_gain``: a multiple of the pixels per clock, at most the columns, whose line's
last word clock carries a multiple of them).
The top ends in the camera's output links (``[pipeline].output = "links"``), behind the
DDR frame buffer its plan gives it (:func:`tdicam.chain.design.link_plan`: at full width a
kept row takes 25.8 us on the links against the lanes' 10.5 us a line pair,
:func:`tdicam.chain.link_rates.link_times`, and the links carry 10.2 whole frames a second
against the sensor's 25; the buffer, an image of the cut's rows, has its own MIG model):
median3's
image through the frame selector (one image in K = 25 / 5 kept; the cut's lines are one
image, the first, kept) into the 2 TLK2711 framers on their own clock (``link_clk``, half
the blocks' clock in the testbench: the scene's 100 MHz links beside its 200 MHz blocks);
the links' words (IDLEs dropped) are compared with the golden chain's output through
:func:`tdicam.model.frame_select.link_images` and :func:`tdicam.model.tlk2711.tlk2711`
(``mismatches``; the report's ``link_words``, every link's words as captured, decode with
:func:`tdicam.model.tlk2711.decode`).

:func:`camera_rows` makes the ``tdicam bench camera`` rows: two cuts measured, the whole
5144 x 3800 frame pair extrapolated from them (start-up, then cycles and seconds a line).
"""

import os
from dataclasses import replace

from tdicam.bench.util import na_row, row
from tdicam.paths import SCENES

__all__ = ["CAMERA_SCENE", "CUT_LINES", "camera_cut", "camera_front", "camera_run",
           "camera_rows", "extrapolate", "legend"]

#: The whole camera of Ning et al. 2019 (5144 x 3800, two gains, coefficients in DDR).
CAMERA_SCENE = SCENES / "ning2019_gmax0504_full.toml"
#: Lines of the two cuts ``tdicam bench camera`` measures (the second gives the cost a line).
#: The coefficient image is a line a row of the cut, and the NAND simulation model
#: (:class:`~tdicam.hdl.nand_store.NandDeviceSim`) holds at most 255 programmed pages: 22
#: rows of 5144 columns (227 words of 2 pixels a page), so the second cut is 16 lines.
CUT_LINES = (8, 16)


def camera_cut(lines=CUT_LINES[0], *, columns=None, nand_blocks=None, lanes_per_gain=None,
               links=True, link_clock_mhz=None):
    """``(plan, data)`` of the first ``lines`` lines of :data:`CAMERA_SCENE`.

    Parameters
    ----------
    lines : int
        Lines of the cut (reset and signal frames of one line each, a gain).
    columns : int or None
        A narrower sensor (the short form of the test); None: the scene's 5144.
    nand_blocks : int or None
        Blocks of each NAND model (a shorter power-up scan); None: the scene's part.
    lanes_per_gain : int or None
        The sensor's lanes a gain for a narrower cut (``[sensor.lvds].lanes_per_gain``, the
        section's other keys their defaults); None: the scene's 40.
    links : bool
        False: the top ends at median3's stream (``[pipeline].output = "stream"``), not at
        the scene's links.
    link_clock_mhz : float or None
        The links' word clock (``[camera].link_clock_mhz``); None: the scene's 100 MHz. A
        narrow cut with slower links than its lanes gets the frame buffer the whole camera
        has (:func:`tdicam.chain.design.link_plan`).

    The pixels per clock are the whole camera's plan's, whatever ``columns``
    (:func:`tdicam.planning.camera.camera_plan`: the fewest that carry the scene's samples
    at its ``[camera].clock_mhz``; 8).
    """
    from tdicam.chain import design
    from tdicam.chain.cosim import scene_data
    sc, ppc = _cut_scene(lines, columns, lanes_per_gain, links, link_clock_mhz)
    m = int(sc.tdi.stages[0])
    p = design.chain_plan(sc, stages=m, lines=int(lines), ppc=ppc)
    if nand_blocks is not None:
        p = replace(p, steps=tuple(replace(s, device={**s.device, "blocks": int(nand_blocks)})
                                   if s.device else s for s in p.steps))
    data, _ = scene_data(sc, stages=m, dv_over_v=0.0, lines=int(lines))
    return p, data


def _cut_scene(lines, columns=None, lanes_per_gain=None, links=True, link_clock_mhz=None):
    """``(scene, ppc)`` of a cut (:func:`camera_cut`'s arguments): the scene with its
    overrides, the whole camera's plan's pixels per clock."""
    from tdicam.planning.camera import camera_plan
    from tdicam.scene.loader import load_scene
    over = {"run": {"lines": int(lines)}}
    ppc = camera_plan(load_scene(CAMERA_SCENE, overrides=over))["scene"]["ppc"]
    if columns is not None:
        over["sensor"] = {"columns": int(columns)}
    if lanes_per_gain is not None:
        over.setdefault("sensor", {})["lvds"] = {"lanes_per_gain": int(lanes_per_gain)}
    if not links:
        over["pipeline"] = {"output": "stream"}
    if link_clock_mhz is not None:
        over["camera"] = {"link_clock_mhz": float(link_clock_mhz)}
    return load_scene(CAMERA_SCENE, overrides=over), ppc


def camera_front(p, lines=CUT_LINES[0], *, columns=None, lanes_per_gain=None):
    """``front`` of :func:`tdicam.chain.cosim.cosimulate` for a cut's plan ``p`` (the other
    arguments :func:`camera_cut`'s): the cut's lanes (:func:`tdicam.chain.lane_cosim.lanes_of`:
    ideal eyes), the word clock of the front's step, the processing clock at the scene's
    ``[camera].clock_mhz``."""
    from tdicam.chain.lane_cosim import lanes_of
    from tdicam.hdl.lvds_front import WORD_DOMAIN
    sc, _ = _cut_scene(lines, columns, lanes_per_gain)
    return {"lanes": lanes_of(sc.sensor.lvds, p.lanes),
            "word_ns": 1e3 / p.steps[0].clocks[WORD_DOMAIN],
            "proc_ns": 1e3 / sc.camera.clock_mhz}


def camera_run(lines=CUT_LINES[0], sim="verilator", *, columns=None, nand_blocks=None,
               corrupt=None, lanes_per_gain=None, links=True, link_clock_mhz=None):
    """One cut (:func:`camera_cut`) from the sensor's lanes (:func:`camera_front`) through
    the top, to the scene's links (``links``; False: to median3's stream), every tap
    compared with the golden chain
    (:func:`tdicam.chain.cosim.cosimulate`). Returns its report plus ``plan``, ``lines``,
    ``tap_mismatches`` (beats of every tap that differ: ``mismatches`` counts the output
    links' words that differ and the front's status against its golden model,
    ``words_compared`` the words of every link), ``startup_cycles`` (the NAND scan and load
    before the first line), ``load`` (the 1-minute load average after the run)."""
    from tdicam.chain.cosim import cosimulate
    p, data = camera_cut(lines, columns=columns, nand_blocks=nand_blocks,
                         lanes_per_gain=lanes_per_gain, links=links,
                         link_clock_mhz=link_clock_mhz)
    rep = cosimulate(p, data, sim, corrupt=corrupt,
                     front=camera_front(p, lines, columns=columns,
                                        lanes_per_gain=lanes_per_gain))
    rep.update({"plan": p, "lines": int(lines), "load": os.getloadavg()[0], "links": links,
                "tap_mismatches": sum(t["mismatches"] for t in rep["taps"]),
                "startup_cycles": int(rep.get("status_outputs", {}).get("startup_cycles", 0))})
    return rep


def extrapolate(a, b, lines):
    """``(cycles, run seconds)`` of ``lines`` lines, linear in the lines from two
    :func:`camera_run` reports ``a`` and ``b`` of fewer lines (the start-up is in both)."""
    n = b["lines"] - a["lines"]
    per_c = (b["cycles"] - a["cycles"]) / n
    per_s = (b["run_seconds"] - a["run_seconds"]) / n
    k = lines - a["lines"]
    return a["cycles"] + per_c * k, a["run_seconds"] + per_s * k


def camera_rows(*, sims, repeat, quick, stalls, build):
    """``tdicam bench camera``: the cuts of :data:`CUT_LINES` lines at full width on
    Verilator (one run each; ``repeat``, ``quick`` and ``stalls`` not used: the DDR and
    NAND models' own stalls only), then the whole frame pair extrapolated; Icarus: a row
    saying why not."""
    rows = []
    if "icarus" in sims:
        rows.append(na_row("camera", "icarus fast", "pixel",
                           "the full-width camera on Icarus: too slow (Verilator only)"))
    if "verilator" not in sims:
        return rows
    runs = [camera_run(n) for n in CUT_LINES]
    for r in runs:
        p, n = r["plan"], r["input_pixels"]
        bad = r["mismatches"] + r["tap_mismatches"]
        rows.append(row(
            "camera", f"verilator fast ppc {p.ppc}", "pixel", n, r["run_seconds"],
            input=f"{p.width} x {r['lines']} lines x {p.lanes} gains", build_s=r["build_seconds"],
            mismatches=bad, accuracy="bit-exact" if bad == 0 else f"{bad} mismatching",
            note=f"{r['cycles']:,} cycles ({r['startup_cycles']:,} the NAND scan and load), "
                 f"{r['cycles'] / r['run_seconds']:,.0f} cycles/s; "
                 + f"every tap and the {r.get('words_compared', 0):,} link words compared"
                 + (f" (the frame buffer: {r['frame_buffer']['writes']:,} words written, "
                    f"{r['frame_buffer']['reads']:,} read)" if r.get("frame_buffer") else "")
                 + _ddr_words(r.get("status_outputs", {}))
                 + f"; load {r['load']:.1f}"))
    rows_full = int(_full_rows())
    cyc, secs = extrapolate(runs[0], runs[1], rows_full)
    p = runs[0]["plan"]
    n = 2 * rows_full * p.width * p.lanes            # reset and signal frames, both gains
    rows.append(row(
        "camera", f"verilator fast ppc {p.ppc} (extrapolated)", "pixel", n, secs,
        input=f"{p.width} x {rows_full} lines x {p.lanes} gains", accuracy="n/a",
        note=f"the whole frame pair, linear from the {CUT_LINES[0]}- and {CUT_LINES[1]}-line "
             f"cuts: {cyc:,.0f} cycles; not run"))
    return rows


def _ddr_words(status):
    """The note's DDR words of each gain channel's interface (its blocks' and its share of
    the frame buffer's), from a run's status; "" without a shared interface."""
    sfx = [s for s in ("", "_1") if f"ddr_writes{s}" in status]
    return "" if not sfx else "; each gain's DDR " + ", ".join(
        f"{status[f'ddr_writes{s}']:,} words written and {status[f'ddr_reads{s}']:,} read"
        for s in sfx)


def _full_rows():
    from tdicam.scene.loader import load_scene
    return load_scene(CAMERA_SCENE).sensor.rows


def legend(*, stalls, quick):
    """What the ``camera`` rows of :func:`camera_rows` mean (lines under the table)."""
    from tdicam.chain.link_rates import link_times
    from tdicam.scene.loader import load_scene
    links_us, lanes_us = link_times(load_scene(CAMERA_SCENE))
    return (f"camera rows: the first {' and '.join(map(str, CUT_LINES))} lines of "
            f"{CAMERA_SCENE.name} (all its columns, both gains: each line a reset frame and a "
            f"signal frame; the NAND scan and coefficient load into DDR at power-up, the "
            f"reset lines and coefficients through each channel's DdrArbiter and MIG model) "
            f"through the generated top on Verilator (cocotb), from the sensor's 80 lanes "
            f"(the lanes' training, then every line's words on them: the chain's lane model, "
            f"the word clock at 25 MHz beside the 200 MHz processing clock), no idle or "
            f"backpressure (--stalls not used), every block's output compared bit for bit "
            f"with the golden chain; the top ends in the 2 TLK2711 links, their words "
            f"compared with the golden chain's through the frame selector and model.tlk2711, "
            f"behind the DDR frame buffer (an image of the cut's rows, its own MIG model): a "
            f"kept row on the links ({links_us:.1f} us) is slower than the lanes' next line "
            f"pair ({lanes_us:.1f} us), which cannot wait; median s = the simulator run's wall time (one run); "
            f"build s: that run's own build (0.0: cached). The extrapolated row: the whole "
            f"frame pair's cycles and seconds, linear in the lines from the two cuts.")
