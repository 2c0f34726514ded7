"""The synthesis record: measured place-and-route results that the rest of tdicam reads.

``tdicam/hw/silicon.json`` (package data) holds one row per measured design: a block at
given parameters, or a scene's whole chain (block ``pipeline``), placed and routed on the
LFE5U-85F speed 8 by ``tdicam synth`` (yosys + nextpnr, ports registered by the timing
harness). ``tdicam plan`` takes the TDI block's Fmax per pixels-per-clock and a scene
chain's Fmax from it (:func:`fmax_by_ppc`, :func:`find`), and docs/guide/silicon.md's
tables state the same figures (a test holds them equal). ``tdicam synth ... --record``
adds or replaces rows (:func:`update`), so a new measurement reaches the plan without
editing code.

A row (:class:`Row`) carries the cell counts, the Fmax median of its placement seeds with
every seed, the target, the date and the machine load of the run (the load changes the
run time, not the figures).
"""

from __future__ import annotations

import datetime
import json
import os
from dataclasses import asdict, dataclass, field
from importlib import resources
from pathlib import Path

from tdicam.errors import TdicamError

__all__ = ["Row", "RECORD", "load", "check_destination", "find", "fmax_by_ppc", "row_of", "update",
           "README_CHAINS", "readme_table", "README_BLOCKS", "readme_blocks_table"]

#: The bundled record (``tdicam/hw/silicon.json``).
RECORD = resources.files("tdicam.hw") / "silicon.json"

_COUNTS = ("lut4", "ccu2c", "comb", "ff", "dp16kd", "mult18")


@dataclass(frozen=True)
class Row:
    """One measured design.

    Attributes
    ----------
    label : str
        Unique name of the row (the silicon table's first column).
    block : str
        A registered block's name, or ``pipeline`` for a scene's chain.
    params : dict
        The block's parameters as synthesized (for ``pipeline``: ``scene`` (file name),
        ``blocks``, ``width``, ``stages``, ``ppc``).
    fmax_mhz : float
        Median Fmax over :attr:`fmax_seeds` (MHz, ECP5-85F speed 8, nextpnr's estimate).
    fmax_seeds : list of float
        Fmax of each placement seed (sorted).
    target_mhz : float
        nextpnr's ``--freq``; the row "meets" it when ``fmax_mhz >= target_mhz``.
    fmax_clocks : dict or None
        Each clock's own Fmax, {clock: median MHz over the seeds}, for a design with more
        than one clock domain (the slowest of them is :attr:`fmax_mhz`); None: not recorded.
    lut4, ccu2c, comb, ff, dp16kd, mult18 : int or None
        ECP5 cell counts of the top (None: not recorded).
    xc7 : dict or None
        yosys ``synth_xilinx -family xc7`` counts (``LUT``, ``LUTRAM+SRL``, ``FF``,
        ``RAMB36``, ``RAMB18``, ``DSP48``), when run.
    tool_seconds : float or None
        Seconds of yosys + nextpnr (at the row's load).
    date : str
        ISO date of the measurement.
    load : str
        The machine's load average during the run ("" when not recorded).
    tools : str
        Tool versions.
    note : str
        Anything the figures need to be read right.
    """

    label: str
    block: str
    params: dict
    fmax_mhz: float
    fmax_seeds: list
    target_mhz: float
    date: str
    lut4: int | None = None
    ccu2c: int | None = None
    comb: int | None = None
    ff: int | None = None
    dp16kd: int | None = None
    mult18: int | None = None
    xc7: dict | None = None
    tool_seconds: float | None = None
    load: str = ""
    tools: str = ""
    note: str = field(default="", compare=False)
    fmax_clocks: dict | None = None

    @property
    def meets(self) -> bool:
        """True when the median Fmax reaches the target."""
        return self.fmax_mhz >= self.target_mhz


def _rows(doc, where):
    if not isinstance(doc, dict) or not isinstance(doc.get("rows"), list):
        raise TdicamError(f"{where}: not a tdicam synthesis record (no 'rows' list)")
    out = []
    for k, r in enumerate(doc["rows"]):
        try:
            row = Row(**r)
        except TypeError as e:
            raise TdicamError(f"{where}: row {k}: {e}") from None
        if not isinstance(row.fmax_mhz, (int, float)) or not row.fmax_mhz > 0:
            raise TdicamError(f"{where}: row {row.label!r}: fmax_mhz must be > 0, got "
                              f"{row.fmax_mhz!r}")
        out.append(row)
    labels = [r.label for r in out]
    dup = sorted({x for x in labels if labels.count(x) > 1})
    if dup:
        raise TdicamError(f"{where}: label {dup[0]!r} is in more than one row")
    return out


def load(path: str | Path | None = None) -> list[Row]:
    """The rows of the record at ``path`` (default: the bundled :data:`RECORD`).

    Raises
    ------
    TdicamError
        A missing, unreadable or malformed record (one line naming the file).
    """
    from tdicam.files import MAX_TOML_BYTES, read_bytes
    src = RECORD if path is None else Path(path)
    try:
        raw = src.read_bytes() if path is None else read_bytes(src, "synthesis record",
                                                                MAX_TOML_BYTES)
        doc = json.loads(raw.decode("utf-8"))
    except TdicamError:
        raise
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise TdicamError(f"{src}: cannot read the synthesis record: "
                          f"{getattr(e, 'strerror', None) or e}") from None
    return _rows(doc, str(src))


def find(block: str, rows: list[Row] | None = None, **params) -> list[Row]:
    """The rows of ``block`` whose parameters include ``params`` (every given key equal)."""
    rows = load() if rows is None else rows
    return [r for r in rows if r.block == block
            and all(r.params.get(k) == v for k, v in params.items())]


def fmax_by_ppc(block: str, rows: list[Row] | None = None, **params) -> dict[int, float]:
    """``{ppc: Fmax MHz}`` of ``block``'s rows matching ``params`` (ppc 1 when a row has no
    ``ppc``); the newest row wins where two share a ppc."""
    out, when = {}, {}
    for r in find(block, rows, **params):
        ppc = int(r.params.get("ppc", 1))
        if ppc not in when or r.date >= when[ppc]:
            out[ppc], when[ppc] = float(r.fmax_mhz), r.date
    return dict(sorted(out.items()))


def row_of(label: str, block: str, params: dict, result, *, target_mhz: float,
           tools: str = "", note: str = "", load: str | None = None) -> Row:
    """A :class:`Row` from a :class:`tdicam.hw.synth.SynthResult` measured now (``load``:
    the 1-minute load average when not given)."""
    x = result.xilinx or {}
    x = {"LUT": x.get("LUT", 0), "LUTRAM+SRL": x.get("LUTRAM", 0) + x.get("SRL", 0),
         "FF": x.get("FF", 0), "RAMB36": x.get("RAMB36", 0), "RAMB18": x.get("RAMB18", 0),
         "DSP48": x.get("DSP48", 0)} if x else None
    return Row(label=label, block=block, params=_plain(params),
               fmax_mhz=round(float(result.fmax_mhz), 1),
               fmax_seeds=sorted(round(float(f), 1) for f in result.fmax_seeds),
               target_mhz=float(target_mhz), date=datetime.date.today().isoformat(),
               **{k: int(getattr(result, k)) for k in _COUNTS},
               xc7=x, tool_seconds=round(float(result.tool_seconds)),
               load=f"{os.getloadavg()[0]:.1f}" if load is None else load, tools=tools,
               note=note, fmax_clocks=dict(getattr(result, "fmax_clocks", None) or {}) or None)


def _plain(params):
    return {k: (v if isinstance(v, (bool, int, float, str, type(None))) else str(v))
            for k, v in params.items()}


def _plain_row(row):
    """A row as the record stores it (``fmax_clocks`` only when recorded)."""
    d = asdict(row)
    if d["fmax_clocks"] is None:
        del d["fmax_clocks"]
    return d


def check_destination(path: str | Path | None = None) -> Path:
    """Check before any work that :func:`update` can write the record at ``path`` (``--record
    FILE``; default the bundled file): an existing file must be a synthesis record, a new
    one a file that can be created. Returns the path.

    Raises
    ------
    TdicamError
        One line naming ``--record`` or the file.
    """
    from tdicam.files import check_file
    dest = Path(str(RECORD)) if path is None else check_file(path, "--record")
    if dest.exists():
        load(dest)
    return dest


def update(new: list[Row], path: str | Path | None = None) -> Path:
    """Add ``new`` to the record at ``path`` (default: the bundled file; a row with the
    same label is replaced) and write it back, rows sorted by label. Returns the path.

    Raises
    ------
    TdicamError
        The record cannot be read or written (e.g. an installed, read-only package).
    """
    dest = Path(str(RECORD)) if path is None else Path(path)
    rows = {r.label: r for r in (load(dest) if dest.exists() else [])}
    rows.update({r.label: r for r in new})
    doc = {"about": "tdicam synthesis record: place-and-route results read by tdicam plan "
                    "and stated in docs/guide/silicon.md (tdicam.hw.record)",
           "rows": [_plain_row(rows[k]) for k in sorted(rows)]}
    try:
        dest.write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    except OSError as e:
        raise TdicamError(f"{dest}: cannot write the synthesis record: {e.strerror}") from None
    return dest


def _newest(rows):
    """The most recently measured of ``rows`` (None when there is none)."""
    return max(rows, key=lambda r: r.date, default=None)


#: The README's silicon table: (scene file, pixels per clock, its variant, what it is) of
#: each row, the newest recorded ``pipeline`` row of that scene, ppc and variant (``phy``,
#: the lanes' PHY, and ``bus``, the control bus; a row without one: ``none``)
#: (:func:`readme_table`).
README_CHAINS = (
    ("orbit_chain.toml", 8, {}, "orbit chain (Qu et al. 2010 design point): nuc -> tdi "
     "-> median3 (at 1 after an 8:1 width converter), 1280 columns x 96 stages, "
     "`--no-csr`"),
    ("orbit_chain.toml", 8, {"bus": "axi4-lite"}, "the same chain with its control bus "
     "(the default: AXI4-Lite slave, register file, irq)"),
    ("orbit_chain.toml", 8, {"bus": "wishbone"}, "the same chain with `--bus wishbone`"),
    ("ning2019_chain.toml", 8, {}, "Ning et al. 2019 chain: cds -> nuc -> hdr -> tdi -> "
     "median3 (at 1 after an 8:1 width converter), 256 columns"),
    ("ning2019_gmax0504_system_lanes.toml", 1, {}, "Ning et al. 2019 camera from the "
     "sensor's lanes: lvds -> cds_ddr -> nuc (NAND) -> hdr -> tdi -> median3, 256 columns"),
    ("ning2019_gmax0504_system_lanes.toml", 1, {"phy": "ecp5", "bus": "axi4-lite"}, "the "
     "same camera behind the ECP5 PHY (`--phy ecp5`: LVDS pins -> DELAYF -> IDDRX2F; the bit "
     "clock ECLK constrained at 150 MHz, 300 Mbit/s DDR, clocks only the IDDRX2F: nextpnr "
     "times no path on it; sclk = ECLK / 2 through CLKDIVF, 75 MHz), with its control bus "
     "(AXI4-Lite), LUTs mapped by the older ABC (`--no-abc9`: ABC9 fails on this netlist)"),
    ("ning2019_gmax0504_full.toml", 8, {}, "the whole Ning et al. 2019 camera on one "
     "device, 5144 x 3800, 2 gains, from its 80 lanes to its 2 TLK2711 links"),
    ("ning2019_gmax0504_full.toml", 8, {"part": "front"}, "the whole Ning et al. 2019 "
     "camera, 5144 x 3800, split over two devices (`--part`), the first: the front end, "
     "80 lanes (training, deskew) to the pixel stream of both gains"),
    ("ning2019_gmax0504_full.toml", 8, {"part": "chain"}, "the second device: the pixel "
     "stream to the 2 TLK2711 links: cds_ddr -> nuc_ddr (NAND) -> hdr -> tdi (1 stage) -> "
     "median3 -> frame selector, reset frames and per-pixel NUC coefficients in DDR through "
     "a DdrArbiter an interface"),
)

#: The parameters that tell a scene's rows apart in :data:`README_CHAINS` (a row without
#: one: ``"none"``).
VARIANT_KEYS = ("phy", "bus", "part")


def readme_table(rows: list[Row] | None = None, *, limits: dict) -> str:
    """The README's "Silicon (ECP5-85F)" table, from the record: one row per
    :data:`README_CHAINS` entry that has a measurement (the newest), with its cells, its
    Fmax per clock domain (:attr:`Row.fmax_clocks`; the slowest alone when not recorded)
    and whether it fits the part (``limits``: {count name: the part's cells}, e.g.
    :data:`tdicam.chain.design.ECP5_85F`)."""
    rows = load() if rows is None else rows
    out = ["| design | ppc | LUT4 | COMB | FF | DP16KD | MULT18 | Fmax per clock domain, MHz "
           "(clk target) | fits |", "|---|---|---|---|---|---|---|---|---|"]
    for scene, ppc, variant, what in README_CHAINS:
        found = [r for r in find("pipeline", rows, scene=scene)
                 if int(r.params.get("ppc", 1)) == ppc and all(
                     r.params.get(k, "none") == variant.get(k, "none") for k in VARIANT_KEYS)]
        if not found:
            continue
        r = _newest(found)
        clocks = r.fmax_clocks or {"clk": r.fmax_mhz}
        fmax = ", ".join(f"{name} {mhz:.1f}" for name, mhz in clocks.items())
        seeds = "1 seed" if len(r.fmax_seeds) == 1 else f"{len(r.fmax_seeds)} seeds"
        over = [k for k, v in limits.items() if getattr(r, k) is not None and
                getattr(r, k) > v]
        fits = "yes" if not over else "no: " + ", ".join(
            f"{k} {getattr(r, k)} > {limits[k]}" for k in over)
        out.append(f"| {what} (`scenes/{scene}`) | {ppc} | {r.lut4} | {r.comb} | {r.ff} | "
                   f"{r.dp16kd} | {r.mult18} | {fmax} ({r.target_mhz:g}; {seeds}) | {fits} |")
    return "\n".join(out) + "\n"


#: The README's table of stream blocks at 8 pixels per clock: (block, variant parameters,
#: what it is) of each row, the newest recorded ppc-8 row of that block and variant beside
#: its ppc-1 row (:func:`readme_blocks_table`).
README_BLOCKS = (
    ("cds", {}, "cds"),
    ("cds_ddr", {}, "cds_ddr (reset frames through DDR)"),
    ("nuc", {}, "nuc"),
    ("hdr", {}, "hdr"),
    ("median3", {}, "median3"),
    ("median3", {"enhance": True}, "median3 with edge enhancement"),
    ("tdi", {}, "tdi (1280 x 96 stages)"),
)


#: The flags that make a measured block a variant of its own (not the plain block's row).
_VARIANT_FLAGS = ("enhance",)


def _variant(row, variant):
    return all(bool(row.params.get(k)) == bool(variant.get(k)) for k in _VARIANT_FLAGS)


def readme_blocks_table(rows: list[Row] | None = None) -> str:
    """The README's "stream blocks at 8 pixels per clock" table, from the record: one row per
    :data:`README_BLOCKS` entry with a ppc-8 measurement (the newest): its cells, LUT4 as a
    multiple of the same block's newest ppc-1 row ("-" when none is recorded), its Fmax
    median with the seeds' range and count, and whether it meets its target."""
    rows = load() if rows is None else rows
    out = ["| block | LUT4 ppc 8 (x ppc 1) | FF | DP16KD | MULT18 | Fmax MHz ppc 8 "
           "(min-max, seeds) | target |", "|---|---|---|---|---|---|---|"]
    for block, variant, what in README_BLOCKS:
        mine = [r for r in find(block, rows) if _variant(r, variant)]
        by_ppc = {p: [r for r in mine if int(r.params.get("ppc", 1)) == p] for p in (1, 8)}
        if not by_ppc[8]:
            continue
        r, one = _newest(by_ppc[8]), _newest(by_ppc[1])
        ratio = f" ({r.lut4 / one.lut4:.1f}x)" if one and one.lut4 and r.lut4 else " (-)"
        cell = lambda v: "-" if v is None else str(v)   # noqa: E731
        seeds = f"{min(r.fmax_seeds):.1f}-{max(r.fmax_seeds):.1f}, {len(r.fmax_seeds)}"
        met = "met" if r.meets else "**not met**"
        out.append(f"| {what} | {cell(r.lut4)}{ratio} | {cell(r.ff)} | {cell(r.dp16kd)} | "
                   f"{cell(r.mult18)} | {r.fmax_mhz:.1f} ({seeds}) | {r.target_mhz:g}: {met} |")
    return "\n".join(out) + "\n"
