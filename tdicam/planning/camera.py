"""The camera budget of ``tdicam plan``: every rate of a whole area camera and its margin.

For a scene with a ``[camera]`` section (the keys of :data:`tdicam.model.physics.camera.KEYS`,
defaults the camera of Ning et al. 2019): the sensor's lanes, the samples a gain channel a
second, the processing clock x pixels per clock, each DDR interface's traffic (per-pixel
coefficients read, the reset frame written and read) against its peak x the measured
efficiency and its capacity, the NAND power-up load and the output links' payload against the
output image rate; the highest frame rate each part carries, the rate the camera sustains
and the part that limits it; the same with the paper's own configuration, and when the paper's
memory cannot carry the coefficients, the options that can, as numbers. The arithmetic is
:mod:`tdicam.model.physics.camera`'s; every figure comes from the scene.
"""

from __future__ import annotations

import dataclasses

from tdicam import blocks as _blocks
from tdicam.model import ddr as _ddr
from tdicam.model import lvds_front
from tdicam.model.physics import camera
from tdicam.chain.link_rates import link_buffer_images
from tdicam.beats import PPC_CHOICES

__all__ = ["camera_budget", "camera_plan", "camera_lines", "chain_silicon", "front_rate"]


def _lanes(scene):
    """``(lanes_per_gain, word_bits, bit_rate_bps, source)`` of the sensor's lanes:
    ``[sensor.lvds]``, or the GMAX0504 front's (its defaults) when the scene gives none."""
    lv = scene.sensor.lvds
    if lv is not None:
        return lv.lanes_per_gain, lv.word_bits, lv.bit_rate_mbps * 1e6, "[sensor.lvds]"
    d = lvds_front.GMAX0504
    return (d["lanes_per_gain"], d["word_bits"], d["bit_rate_mbps"] * 1e6,
            "the GMAX0504's lanes ([sensor.lvds] defaults)")


def _row(name, need, avail, unit, fix, text, *, limit=None, ok=None):
    ok = (need <= avail * (1 + 1e-12)) if ok is None else ok
    return {"name": name, "need": need, "available": avail, "unit": unit,
            "margin": None if not need else avail / need - 1.0, "ok": bool(ok),
            "frame_rate_limit": limit, "text": text, "fix": None if ok else fix}


def _chain_facts(scene):
    """``(reset, reset_ddr, coefficients)`` of the scene's chain, from the blocks' registry
    entries: a block takes the sensor's reset frames (its own ``reset_frames``, or that of
    the DDR variant it spills to), the scene keeps them in DDR (the block's placement), a
    block applies per-pixel calibration coefficients (it has identity coefficients,
    :attr:`tdicam.blocks.Use.identity`)."""
    reset = reset_ddr = coeffs = False
    for name in scene.pipeline.blocks:
        u = _blocks.get(name).pipeline
        spill = _blocks.get(u.memory.spill).pipeline if u.memory.spill else None
        if u.reset_frames or (spill is not None and spill.reset_frames):
            reset = True
            reset_ddr = reset_ddr or u.reset_frames or (
                u.memory.placement is not None and u.memory.placement(scene) == "ddr")
        coeffs = coeffs or u.identity is not None
    return reset, reset_ddr, coeffs


def samples_per_s(scene, cam, reset=None):
    """Samples a gain channel a second the camera ``cam`` reads: ``k C R F`` (``k`` = 2 with
    the sensor's reset frames, 1 without; ``reset``: whether the chain takes them, None:
    from the scene's chain): the rate the whole chain's input must take."""
    s = scene.sensor
    reset = _chain_facts(scene)[0] if reset is None else reset
    return (2 if reset else 1) * s.columns * s.rows * cam.frame_rate_hz


def front_rate(scene):
    """Pixels a second a gain channel the lanes' front end takes while a line arrives (its
    ``columns`` in the line's ``P + 2`` word clocks, :func:`tdicam.model.lvds_front.min_proc_mhz`
    x ppc): what the processing clock x ppc behind the crossing FIFO must carry, a little
    above the samples a second when the sensor's lines follow with no blanking; None without
    ``[sensor.lvds]``."""
    lv = scene.sensor.lvds
    if lv is None:
        return None
    return 1e6 * lvds_front.min_proc_mhz(lv.lanes_per_gain, 1, scene.sensor.columns,
                                         lv.bit_rate_mbps / lv.word_bits)


def camera_budget(scene, cam):
    """The budget of ``scene`` with the camera configuration ``cam``
    (:class:`tdicam.model.physics.camera.Camera`): ``rows`` (each ``name``, ``need``,
    ``available``, ``unit``, ``margin``, ``ok``, ``frame_rate_limit`` or None, ``text``,
    ``fix``: what makes a NO yes), ``sustained_hz``, ``limiter``, ``feasible`` and the key
    figures."""
    s = scene.sensor
    C, R, G = s.columns, s.rows, len(s.gains)
    reset, reset_ddr, nuc = _chain_facts(scene)
    k = 2 if reset else 1
    F, Fo = cam.frame_rate_hz, cam.output_frame_rate_hz
    rows = []

    L, wb, bit_rate, lane_src = _lanes(scene)
    need, cap, lim = camera.lane_figures(C, R, k * F, L, G, wb, bit_rate)
    per_lane = camera.lane_words_per_line(C, L)
    rows.append(_row(
        "lanes", need, cap, "bit/s",
        f"{k * R * per_lane * wb * F / 1e6:.1f} Mbit/s a lane (faster lanes) or fewer rows",
        f"{L * G} lanes x {bit_rate / 1e6:g} Mbit/s of {wb}-bit words ({lane_src}) = "
        f"{cap / 1e9:.2f} Gbit/s; {k} x {R} lines x {per_lane} words a lane ({per_lane - 2} "
        f"pixel words, {lvds_front.padded_slots(C, L)} padded slots a gain, sync and header) at "
        f"{F:g} frame/s need {need / 1e9:.2f} Gbit/s", limit=lim / k))

    samples = samples_per_s(scene, cam, reset)
    clock = cam.clock_mhz * 1e6
    ppc, pcap, pok = camera.processing_figures(samples, clock)
    rows.append(_row(
        "processing", samples, pcap, "sample/s",
        f"a clock of {samples / PPC_CHOICES[-1] / 1e6:.1f} MHz at ppc "
        f"{PPC_CHOICES[-1]}",
        f"{k} x {C} x {R} x {F:g} = {samples / 1e6:.2f} M samples/s a gain channel"
        f"{' (reset frames included)' if reset else ''}; {cam.clock_mhz:g} MHz x ppc {ppc} "
        f"= {pcap / 1e6:.0f} M/s", limit=F * pcap / samples, ok=pok))

    coeff_ch = (G if cam.nuc == "per_gain" else 1) if nuc else 0
    traffic, reset_line, coeff_line = camera.ddr_words_per_frame(
        C, R, pixel_bits=s.bits, gains=G, reset=reset_ddr, coeff_bits=cam.coeff_bits,
        coeff_channels=coeff_ch)
    lneed, payload, llim = camera.link_figures(R, C, frames_per_s=Fo,
                                             pixel_bits=cam.link_pixel_bits,
                                             links=cam.links, clock_hz=cam.link_clock_mhz * 1e6)
    # the scene's own top builds its buffer (tdicam.chain.design.link_plan) from its [camera]
    built = scene.pipeline.output == "links" and link_buffer_images(scene) > 0
    fb_line, fb_write, fb_read, fb_images = camera.frame_buffer_words(
        C, R, pixel_bits=cam.link_pixel_bits, frame_rate_hz=F, output_frame_rate_hz=Fo,
        link_frame_rate_hz=llim)
    traffic = {**traffic, "image write": fb_write, "image read": fb_read}
    # where the top puts it (tdicam.hdl.chain_top.Pipeline): beside the DDR blocks, or alone
    fb_where = (f"its rows dealt in turn to the {G} channels' DDR interfaces, each behind the "
                f"interface's DdrArbiter beside the blocks there" if coeff_ch or reset_ddr
                else "on a MIG user interface of its own, frame_buffer_app_*")
    n_if = cam.ddr_interfaces
    peak, pins, user = camera.ddr_peak_bps(cam.ddr_data_bits, cam.ddr_data_rate_mts,
                                         cam.ddr_user_clock_mhz)
    eff, eff_src = camera.ddr_efficiency(shared=bool(coeff_ch) and reset_ddr)
    avail = peak * eff
    words = sum(traffic.values()) / n_if
    dneed = words * _ddr.WORD_BITS * F
    # the frame buffer's read goes at the links' pace, whatever the sensor's frame rate
    fixed = fb_read / n_if * _ddr.WORD_BITS * F
    per_frame = dneed / F - fixed / F
    parts = ", ".join(f"{n} {v / n_if * _ddr.WORD_BITS * F / 1e9:.2f}"
                      for n, v in traffic.items() if v)
    rows.append(_row(
        "DDR interface", dneed, avail, "bit/s",
        f"{dneed / eff / 1e9:.2f} Gbit/s of peak an interface: see the options",
        f"each of {n_if} interface(s) ({cam.ddr_data_bits}-bit, {cam.ddr_data_rate_mts:g} "
        f"MT/s = {pins / 1e9:.1f} Gbit/s, user clock {cam.ddr_user_clock_mhz:g} MHz = "
        f"{user / 1e9:.1f} Gbit/s; peak {peak / 1e9:.1f} x {eff:.1%} = {avail / 1e9:.2f} "
        f"Gbit/s, {eff_src}) moves {parts} Gbit/s (coefficients {coeff_line} words a line "
        f"of {cam.coeff_bits}-bit gain and offset, {coeff_ch} channel(s); reset lines "
        f"{reset_line} words, 24 pixels a word"
        + (f"; the frame buffer before the links: an image sent written at {F:g} frame/s "
           f"as the chain makes it and read at the links' {llim:.2f}, {fb_line} words a "
           f"line of {cam.link_pixel_bits}-bit pixels" if fb_write else "")
        + ")", limit=max(avail - fixed, 0.0) / per_frame if per_frame else None))

    # capacity: a line at a power-of-two stride (Table 2: 4096 addresses for 512 words)
    def stride(w):
        return 1 << (max(w, 1) - 1).bit_length() if w else 0
    lines = coeff_ch * R * stride(coeff_line) + (G * R * stride(reset_line) if reset_ddr else 0) \
        + fb_images * R * stride(fb_line)
    used = lines * _ddr.WORD_BITS / 8 / n_if
    capacity = _ddr.CAPACITY_BYTES * cam.ddr_data_bits / 32
    rows.append(_row(
        "DDR capacity", used, capacity, "B", "more or larger SDRAMs",
        f"{used / 2**20:.0f} MiB an interface (lines at a power-of-two stride: reset "
        f"{stride(reset_line)} words, coefficients {stride(coeff_line)}"
        + (f", {fb_images} image(s) of the frame buffer {stride(fb_line)}" if fb_images else "")
        + f") of {capacity / 2**30:g} GiB"))

    if coeff_ch:
        secs, used_b, free_b, one = camera.nand_figures(R, C, coeff_ch, cam.nand_parts)
        rows.append(_row(
            "NAND load", used_b, free_b, "blocks", "a larger or a second NAND part",
            f"power-up load of {coeff_ch} coefficient image(s) ({R} x {C}, 4 coefficients "
            f"a 72-bit word) from {cam.nand_parts} part(s): {secs:.2f} s (scan "
            f"{one.scan_s * 1e3:.0f} ms, {one.load_s:.2f} s and {one.pages} pages an image, "
            f"at the controller's {one.clock_hz / 1e6:g} MHz); {used_b} of {free_b} "
            f"blocks a part"))
        rows[-1]["seconds"] = secs

    rows.append(_row(
        "output links", Fo, llim, "frame/s",
        f"output_frame_rate_hz <= {llim:.2f} (a window of fewer rows, more links, or "
        f"fewer bits a pixel)",
        f"{cam.links} TLK2711 x 16 bit x {cam.link_clock_mhz:g} MHz = {payload / 1e9:.2f} "
        f"Gbit/s; the {C} x {R} image of {cam.link_pixel_bits}-bit pixels at {Fo:g} "
        f"frame/s is {lneed / 1e9:.2f} Gbit/s; with the framing the links carry "
        f"{llim:.2f} frame/s"
        + (f"; an image sent takes {1e3 / llim:.1f} ms on them against the "
           f"{1e3 / F:.1f} ms the sensor reads it in, so it waits in a DDR frame buffer "
           f"({fb_images} image(s) of room"
           + (f"; the generated top has it before its links, {fb_where})" if built else ")")
           if fb_write else ""),
        limit=llim))

    limits = {r["name"]: r["frame_rate_limit"] for r in rows
              if r["frame_rate_limit"] is not None}
    limiter = min(limits, key=limits.get)
    read = {n: v for n, v in limits.items() if n != "output links"}
    read_limiter = min(read, key=read.get)
    no = [r["name"] for r in rows if not r["ok"]]
    return {"rows": rows, "frame_rate_hz": F, "output_frame_rate_hz": Fo,
            "frame_buffer": {"line_words": fb_line, "images": fb_images,
                             "built": built} if fb_write else None,
            "samples_per_gain_s": samples, "ppc": ppc, "ddr_words_per_frame": traffic,
            "ddr_efficiency": eff, "limits": limits, "sustained_hz": limits[limiter],
            "limiter": limiter, "read_limit_hz": read[read_limiter],
            "read_limiter": read_limiter, "infeasible": no, "feasible": not no,
            "config": dataclasses.asdict(cam)}


def chain_silicon(chain):
    """The synthesis record's rows that stand for the chain as built, from the plan's
    ``gateware.chain`` entries (each ``part``, ``date``, ``pixel_rate``, ``meets``): the
    fastest whole top's row (``[row]``) when it keeps up or the record holds no split
    camera with every part; else the newest row of each part of the split (``tdicam synth
    pipeline --part``: front, chain). None when the record has neither."""
    from tdicam.chain.design import PARTS
    whole = [c for c in chain if c["part"] == "whole"]
    best = max(whole, key=lambda c: c["pixel_rate"]) if whole else None
    newest = {}
    for c in chain:
        if c["part"] != "whole" and (c["part"] not in newest
                                     or c["date"] >= newest[c["part"]]["date"]):
            newest[c["part"]] = c
    split = [newest[p] for p in PARTS[1:]] if set(newest) == set(PARTS[1:]) else None
    if best is not None and (best["meets"] or split is None):
        return [best]
    return split


def _silicon(chain, budget):
    """The scene's camera on the recorded silicon: the chain's rows
    (:func:`chain_silicon`); the frame rate each reads, ``F x pixel rate / samples`` a gain
    (a split's front device: any while it takes a line from the lanes as fast as they send
    it, its ``meets``, none when it does not: it loses words whatever the frame rate),
    beside the budget's lanes' and DDR's limits; the lowest is the frame rate the camera
    reads and its part the limit. None without a record."""
    rows = None if not chain else chain_silicon(chain)
    if rows is None:
        return None
    F = budget["frame_rate_hz"]
    limits = {n: v for n, v in budget["limits"].items()
              if n not in ("processing", "output links")}
    for c in rows:
        name = "whole top" if c["part"] == "whole" else f"{c['part']} device"
        if c["part"] != "front":
            limits[name] = F * c["pixel_rate"] / budget["samples_per_gain_s"]
        elif not c["meets"]:
            limits[name] = 0.0
    limiter = min(limits, key=limits.get)
    return {"rows": [{k: c[k] for k in ("part", "label", "ppc", "fmax_mhz", "seeds", "date",
                                       "pixel_rate", "need", "meets")} for c in rows],
            "read_limit_hz": limits[limiter], "read_limiter": limiter,
            "ok": all(c["meets"] for c in rows) and limits[limiter] >= F * (1 - 1e-12)}


def _options(scene, paper):
    """The configurations that carry the coefficients where the paper's DDR does not."""
    out = []
    for what, change in (("8-bit coefficients", {"coeff_bits": 8}),
                         ("NUC after the HDR merge (one channel)", {"nuc": "merged"}),
                         ("DDR user clock 200 MHz (1600 MT/s at 4:1)",
                          {"ddr_user_clock_mhz": 200.0}),
                         ("4 interfaces (8 SDRAMs x16)", {"ddr_interfaces": 4})):
        b = camera_budget(scene, dataclasses.replace(paper, **change))
        r = next(r for r in b["rows"] if r["name"] == "DDR interface")
        out.append({"option": what, "change": change, "need_bps": r["need"],
                    "available_bps": r["available"], "ok": r["ok"], "margin": r["margin"]})
    return out


def camera_plan(scene, chain=None):
    """The plan's ``camera`` entry for a scene with ``[camera]`` (None without): the budget
    with the scene's configuration, with the paper's (the keys' defaults at the scene's
    frame rates) and, when the paper's DDR cannot carry the traffic, the options;
    ``silicon``: the scene's camera at the clocks its synthesis record reached (``chain``:
    the plan's ``gateware.chain`` rows; :func:`_silicon`), None without a record. The
    budget's processing row is the scene's ``[camera].clock_mhz`` (the device the scene
    names, the paper's XC7K325T); the record is the ECP5-85F's."""
    cam = scene.camera
    if cam is None:
        return None
    paper = camera.Camera(frame_rate_hz=cam.frame_rate_hz,
                        output_frame_rate_hz=cam.output_frame_rate_hz)
    pb = camera_budget(scene, paper)
    ddr_ok = next(r for r in pb["rows"] if r["name"] == "DDR interface")["ok"]
    sb = camera_budget(scene, cam)
    return {"scene": sb, "paper": pb, "silicon": _silicon(chain, sb),
            "paper_ddr_ok": ddr_ok,
            "options": None if ddr_ok else _options(scene, paper)}


def _sustains(b) -> str:
    return (f"  reads up to {b['read_limit_hz']:.2f} frame/s from the sensor (limited by "
            f"the {b['read_limiter']}); sustains {b['sustained_hz']:.2f} full frames/s "
            f"out, limited by the {b['limiter']}")


def _table(b) -> list[str]:
    out = [f"  {'part':<14} {'need':>12} {'available':>12} {'margin':>9} "
           f"{'max frame/s':>11}  ok"]
    for r in b["rows"]:
        f = 1e9 if r["unit"] == "bit/s" else 1e6 if r["unit"] == "sample/s" else 1
        unit = {"bit/s": "G", "sample/s": "M", "B": ""}.get(r["unit"], "")
        if r["unit"] == "B":
            f, unit = 2**20, "Mi"
        m = "" if r["margin"] is None else f"{r['margin']:+.1%}"
        lim = "" if r["frame_rate_limit"] is None else f"{r['frame_rate_limit']:.2f}"
        out.append(f"  {r['name']:<14} {r['need'] / f:>11.2f}{unit:<1} "
                   f"{r['available'] / f:>11.2f}{unit:<1} {m:>9} {lim:>11}  "
                   f"{'yes' if r['ok'] else 'NO'}")
    out += [f"    {r['name']}: {r['text']}" + (f" -- NO: needs {r['fix']}" if r["fix"] else "")
            for r in b["rows"]]
    return out


def camera_lines(c) -> list[str]:
    """The report's lines of a :func:`camera_plan` entry."""
    sb, pb = c["scene"], c["paper"]
    out = [f"Camera budget at {sb['frame_rate_hz']:g} frame/s read, "
           f"{sb['output_frame_rate_hz']:g} frame/s out (the scene's [camera]):"]
    out += _table(sb)
    out.append(_sustains(sb))
    out.append(f"  camera at {sb['frame_rate_hz']:g} frame/s read, "
               f"{sb['output_frame_rate_hz']:g} out: "
               + ("yes" if sb["feasible"] else f"NO ({', '.join(sb['infeasible'])})"))
    si = c.get("silicon")
    if si is not None:
        parts = ", ".join(f"{'the ' + r['part'] + ' device' if r['part'] != 'whole' else 'the top'}"
                          f" {r['fmax_mhz']:.1f} MHz x ppc {r['ppc']} = "
                          f"{r['pixel_rate'] / 1e6:.1f} M/s, needs {r['need'] / 1e6:.1f} "
                          f"({r['seeds']} seed(s), {r['date']})"
                          for r in si["rows"])
        out.append(f"  on the synthesis record's ECP5-85F ({parts}): reads up to "
                   f"{si['read_limit_hz']:.2f} frame/s (limited by the {si['read_limiter']})"
                   f": {'yes' if si['ok'] else 'NO'} at {sb['frame_rate_hz']:g} frame/s")
    out.append("For comparison, the paper's configuration (Ning et al. 2019: 2 DDR interfaces of 32 "
               "bit, 1600 MT/s, user clock 100 MHz, 16-bit coefficients, processing at "
               "100 MHz, 2 TLK2711 at 100 MHz; not the scene's verdict):")
    out += _table(pb)
    out.append(_sustains(pb))
    out.append(f"  per-pixel NUC of both gains at {pb['frame_rate_hz']:g} "
               f"frame/s in the paper's DDR: "
               + ("fits" if c["paper_ddr_ok"] else "does NOT fit"))
    for o in c["options"] or ():
        out.append(f"    option {o['option']}: DDR {o['need_bps'] / 1e9:.2f} of "
                   f"{o['available_bps'] / 1e9:.2f} Gbit/s an interface "
                   f"({o['margin']:+.1%}): {'fits' if o['ok'] else 'NO'}")
    return out
