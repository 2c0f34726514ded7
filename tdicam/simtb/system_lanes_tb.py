"""cocotb side of a pipeline co-simulation from the sensor's lanes (see
:func:`tdicam.chain.cosim.run_top` with a ``[sensor.lvds]`` scene).

The DUT is the generated pipeline top whose input is the front's lanes (``lvds_lane_raw``,
the word clock ``word_clk``) with the simulation models of its external parts beside it. The
testbench resets both domains, sets the run-time ports of ``job.json`` (``settings``), and
runs two coroutines: the word side serves each lane's raw word from ``raw.npy`` (``[lane,
tap, cycle]``, :class:`tdicam.cosim.lvds_front.WordDriver`; with ``job["steady"]`` the first
``k0`` cycles, the trained taps' words after them in ``steady.npy``:
:func:`tdicam.cosim.lvds_front.driver_tables`) and notes the word clock at which the lanes
have trained, the calibration is loaded and frames are released; the processing side takes
every output beat and every tap's beats with the processing cycle (until the front first
releases a frame it waits on ``lvds_releasing`` instead of every clock: no beat comes
before). It stops ``drain`` processing clocks after the last expected output beat (or at
``max_cycles``) and writes ``result.json`` (the front's status ports as they were at the end
of the sensor's words, the other status outputs at the end).

With ``job["links"]`` the top ends in the output links (``[pipeline].output = "links"``):
the link clock ``link_clk`` runs at ``job["links"]["link_ps"]`` (its reset ``link_rst``
with the processing one), and the output beats are the links' words instead of
``m_axis``: every link clock on which link 0 sends a word other than IDLE (the links send
their IDLEs together) is one beat, every link's word in it (link ``L``'s at bit
``L * job["links"]["padded"]``).

With ``job["csr"]`` the top has the control bus (``--csr``): the front's status is read
through it (:class:`tdicam.simtb.lanes_bus.LaneBus`: the frame status, the start-up, the
interrupts served), and the registers standing for status ports give those ports' values.
"""

import json
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, First, RisingEdge, Timer
from cocotb.utils import get_sim_time

from tdicam.cosim.lvds_front import WordDriver
from tdicam.simtb.lvds_front_tb import start


def _get(sig):
    return int(sig.value)


@cocotb.test()
async def run_job(dut):
    job = json.loads(Path("job.json").read_text())
    raw = np.load("raw.npy")
    res = {"beats": [], "taps": [[] for _ in job["taps"]], "frame_status": [],
           "events": [], "status": {}, "startup": {}}
    track = bool(job.get("track"))
    if track:                       # the receiver tracks the eyes: log its corrections
        res["corrections"] = []
    bus_idle = [getattr(dut, f"s_axil_{x}") for x in ("awvalid", "wvalid", "bready",
                                                       "arvalid", "rready")] \
        if job.get("csr") else []
    links = job.get("links")
    lclk = None
    if links is not None:               # the links' clock, reset with the processing side
        lclk = Clock(dut.link_clk, links["link_ps"], unit="ps")
        lclk.start()
        dut.link_rst.value = 1
    wclk, pclk = await start(dut, job["word_ps"], job["proc_ps"], job["settings"],
                             (dut.lvds_lane_raw, dut.lvds_retrain, *bus_idle,
                              *(() if links else (dut.m_axis_tready,))))
    if links is not None:
        await FallingEdge(dut.link_clk)
        dut.link_rst.value = 0
    done = [False]
    taps = [[getattr(dut, f"{base}_{s}") for s in ("valid", "ready", "first", "last", "data")]
            for base in job["taps"]]

    async def link_side():
        pins = [[getattr(dut, f"link{k}_{x}") for x in ("txd", "tklsb", "tkmsb")]
                for k in range(links["links"])]
        while True:
            await FallingEdge(dut.link_clk)
            words = [_get(t) | _get(lo) << 16 | _get(hi) << 17 for t, lo, hi in pins]
            if words[0] != links["idle"]:
                res["beats"].append([0, 0, str(sum(w << (k * links["padded"])
                                                   for k, w in enumerate(words))), cyc_now[0]])

    cyc_now = [0]
    # no beat before the front first releases a frame (its ``releasing`` rises at the first
    # released frame's header, before its pixels): until then the processing side waits on
    # that port instead of every clock, its cycles counted from the simulation time
    skip = [bus_idle == [] and hasattr(dut, "lvds_releasing")]

    async def proc_side():
        if links is None:
            dut.m_axis_tready.value = 1
        await FallingEdge(dut.clk)
        t1, cyc = get_sim_time(unit="ps"), 1
        while True:
            cyc_now[0] = cyc
            if links is None and _get(dut.m_axis_tvalid):
                res["beats"].append([_get(dut.m_axis_tuser), _get(dut.m_axis_tlast),
                                     str(_get(dut.m_axis_tdata)), cyc])
            for k, (v, r, f, la, d) in enumerate(taps):
                if _get(v) and _get(r):
                    res["taps"][k].append([_get(f), _get(la), str(_get(d)), cyc])
            if len(res["beats"]) >= job["n_out"] and not done[0]:
                done[0] = True
                res["cycles"] = cyc                 # the last expected output beat
            if (done[0] and cyc >= res.get("cycles", cyc) + job["drain"]) \
                    or cyc >= job["max_cycles"]:
                res.setdefault("cycles", cyc)
                res["timeout"] = not done[0]
                return
            if skip[0]:
                skip[0] = False
                if not _get(dut.lvds_releasing):
                    await First(RisingEdge(dut.lvds_releasing),
                                Timer((job["max_cycles"] - cyc) * job["proc_ps"], unit="ps"))
            await FallingEdge(dut.clk)
            cyc = 1 + round((get_sim_time(unit="ps") - t1) / job["proc_ps"])

    proc = cocotb.start_soon(proc_side())
    if links is not None:
        cocotb.start_soon(link_side())
    st = job.get("steady")
    drv = WordDriver(raw, job["word_bits"], job.get("retrains", ()), res,
                     None if st is None else (st["k0"], st["taps"], np.load("steady.npy")))
    watch = {"lanes_trained": "lvds_trained", "frames_released": "lvds_releasing"}
    now = [0]
    bus = None
    if job.get("csr"):                 # the front's status is on the bus: polled there
        from tdicam.simtb.lanes_bus import LaneBus
        bus = LaneBus(dut, job, res, lambda: now[0])
        poll = cocotb.start_soon(bus.poll())
        watch = {}
    for name in job["ready"] if bus is None else ():
        watch[f"{name}_done"] = name
    front = (lambda x: _get(getattr(dut, "lvds_" + x))) if bus is None else \
        (lambda x: _get(getattr(dut, "lvds_" + x)) if x in ("lane_ld", "lane_tap") else 0)
    last = [0, 0]                           # start() set both to 0
    for kk in range(job["word_cycles"]):
        now[0] = kk
        lane_raw, retrain = drv.inputs(kk)
        if lane_raw != last[0]:              # the lanes' words written when they change
            dut.lvds_lane_raw.value = last[0] = lane_raw
        if retrain != last[1]:
            dut.lvds_retrain.value = last[1] = retrain
        if track:
            dut.lvds_lane_mon_raw.value = drv.mon_inputs(kk)
            drv.mon_observe(_get(dut.lvds_lane_mon_ld), _get(dut.lvds_lane_mon_tap))
        drv.observe(kk, *(front(x) for x in (
            "lane_ld", "lane_tap", "lane_locked", "lane_error", "frames_out")),
            lambda: front("frame_invalid"))
        for key, port in watch.items():
            if key not in res["startup"] and _get(getattr(dut, port)):
                res["startup"][key] = kk
        await FallingEdge(dut.word_clk)
    # the front's status at the end of the sensor's words (past them the lanes stand still
    # and lose their lock); the others once the output has drained
    lanes = {name: _get(getattr(dut, name)) for name in job["status"]
             if name.startswith("lvds_")}
    if bus is not None:
        bus.running = False
        await poll
        lanes.update(await bus.read("lvds"))
    await proc
    for name in job["status"]:
        res["status"][name] = lanes.get(name, _get(getattr(dut, name)))
    if bus is not None:
        res["status"].update({k: v for k, v in (await bus.read()).items() if k not in lanes})
        res["status"].update(lanes)
        res["registers"] = await bus.read_all()
    wclk.stop()
    pclk.stop()
    if lclk is not None:
        lclk.stop()
    await Timer(1, unit="ns")
    Path("result.json").write_text(json.dumps(res))
