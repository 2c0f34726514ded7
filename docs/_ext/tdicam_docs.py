"""Pages of the tdicam docs generated from the code when the site is built.

Two pages hold a placeholder that this extension replaces, when Sphinx reads the page, by
Markdown generated from the package itself (so the page cannot fall behind the code):

* ``{tdicam-blocks}`` (``guide/blocks.md``): the block registry (:mod:`tdicam.blocks`) — an
  overview table, then per block its summary, parameters with ranges and defaults, the
  latency of its Verilog top at the default parameters, its inputs, its ``[pipeline.<block>]``
  scene section and its golden cases;
* ``{tdicam-scenes}`` (``guide/scenes.md``): the bundled scene and sweep files, each with
  the first paragraph of its leading comment;
* ``{tdicam-effects}`` (``guide/run.md``): the scene simulator's effects table
  (:data:`tdicam.engine.effects.EFFECTS`), in the order they are applied;
* ``{tdicam-api}`` (``api.md``): an autosummary table and the autodoc entry of every name in
  ``tdicam.__all__`` (a class with its public members, a function, a module with its own
  ``__all__``).

The placeholder is a fenced block of its own (three backticks, the name in braces, nothing
inside).
"""

from __future__ import annotations

import inspect
import re
import types
from pathlib import Path

PLACEHOLDER = re.compile(r"^```\{(tdicam-[a-z]+)\}\s*\n```\s*$", re.M)
#: The checkout's bundled scenes (the docs are built from a checkout).
SCENES = Path(__file__).resolve().parents[2] / "scenes"


# --------------------------------------------------------------------------------------
# the block registry
# --------------------------------------------------------------------------------------


def _cell(text) -> str:
    """``text`` safe in one cell of a Markdown pipe table."""
    return " ".join(str(text).split()).replace("|", "\\|")


def _range(p) -> str:
    if p.choices is not None:
        return ", ".join(f"`{c}`" for c in p.choices)
    if p.lo is not None or p.hi is not None:
        lo = "" if p.lo is None else p.lo
        hi = "" if p.hi is None else p.hi
        return f"{lo}..{hi}"
    return p.type.__name__


def _default(p) -> str:
    if p.default is None:
        return "derived"
    if p.type is bool:
        return str(bool(p.default)).lower()
    return f"`{p.default}`"


def _latency(blk):
    """Latency in clock cycles of the block's Verilog top at its defaults, or None when the
    top does not state one (plain-port cores, blocks whose latency depends on the data)."""
    try:
        top = blk.build()
    except Exception:           # noqa: BLE001 - a block that needs parameters states none
        return None
    for obj in (getattr(top, "core", None), top):
        lat = getattr(obj, "latency", None)
        if isinstance(lat, int):
            return lat
    return None


def blocks_markdown() -> str:
    """The block registry as Markdown: an overview table and a section per block."""
    from tdicam import blocks

    regs = blocks.all_blocks()
    lat = {b.name: _latency(b) for b in regs}
    out = ["| block | what it is | latency (cycles, defaults) | golden cases |",
           "|---|---|---|---|"]
    for b in regs:
        n = len(b.cases())
        out.append(f"| [`{b.name}`](#block-{b.name}) | {_cell(b.summary)} | "
                   f"{'' if lat[b.name] is None else lat[b.name]} | {n} |")
    for b in regs:
        out += ["", f"(block-{b.name})=", f"### `{b.name}`", "", _cell(b.summary) + ".", ""]
        if b.params:
            out += ["| parameter | range | default | meaning |", "|---|---|---|---|"]
            out += [f"| `--{p.name.replace('_', '-')}` | {_cell(_range(p))} | "
                    f"{_cell(_default(p))} | {_cell(p.help)} |" for p in b.params]
        else:
            out.append("No elaboration parameters.")
        out.append("")
        facts = []
        if lat[b.name] is not None:
            facts.append(f"**Latency**: {lat[b.name]} clock cycles from an accepted input "
                         f"beat to its output at the default parameters (no stalls).")
        if b.to_beats is not None:
            facts.append(f"**Co-simulation**: as a stream against its golden model "
                         f"(`tdicam sim {b.name}`); main input `{b.stream}`.")
        else:
            facts.append("**Co-simulation**: not a video stream; its own cocotb test "
                         f"(`cocotb_tests/test_{b.name}.py`).")
        for s in b.side_inputs:
            facts.append(f"**Side input** `{s.name}` (per {s.per}): {_cell(s.what)}")
        if b.pipeline is not None and b.pipeline.options is not None:
            facts.append(f"**Scene section**: `[pipeline.{b.name}]` "
                         f"([scene reference](../scene-format.md)).")
        elif b.pipeline is not None:
            facts.append("**Pipeline**: can be named in a scene's `[pipeline].blocks`.")
        cases = [c.name for c in b.cases()]
        facts.append(f"**Golden cases** (`golden/{b.name}/`, {len(cases)}): "
                     + ", ".join(f"`{c}`" for c in cases) + ".")
        out += ["* " + f for f in facts]
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------------------
# the bundled scenes
# --------------------------------------------------------------------------------------


def _about(path: Path) -> str:
    """The first paragraph of a TOML file's leading comment, as one line."""
    words = []
    for line in path.read_text().splitlines():
        if not line.startswith("#"):
            break
        text = line[1:].strip()
        if not text:
            if words:
                break
            continue
        words.append(text)
    return " ".join(words)


def scenes_markdown() -> str:
    """The bundled scenes and sweeps as a Markdown list."""
    out = []
    for title, folder in (("Scenes", SCENES), ("Sweeps", SCENES / "sweeps")):
        out += [f"**{title}** (`{folder.relative_to(SCENES.parent).as_posix()}/`):", ""]
        out += [f"* `{p.name}`: {_about(p)}" for p in sorted(folder.glob("*.toml"))]
        out.append("")
    return "\n".join(out)


# --------------------------------------------------------------------------------------
# the scene simulator's effects
# --------------------------------------------------------------------------------------

_STAGES = {"render": "rendering (geometry)", "pattern": "fixed pattern", "charge": "charge",
           "conversion": "conversion (ADC)", "blocks": "blocks before TDI", "tdi": "TDI",
           "output": "after TDI", "": "channels"}


def _fidelity(e) -> str:
    if e.per_exposure:
        return "always exact (non-linear, per exposure)"
    if e.aggregated:
        return "fast: on the sum of the m exposures"
    return "not changed by the fidelity"


def effects_markdown() -> str:
    """The effects table: name (for ``--force``), what it is, stage, fidelity, forcible."""
    from tdicam.engine.effects import EFFECTS
    out = ["| effect | what it is | stage | fidelity | `--force` |", "|---|---|---|---|---|"]
    out += [f"| `{e.name}` | {_cell(e.label)} | {_STAGES.get(e.stage, e.stage)} | "
            f"{_fidelity(e)} | {'yes' if e.forcible else ''} |" for e in EFFECTS]
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------------------
# the public API
# --------------------------------------------------------------------------------------


def _directive(name, obj) -> list[str]:
    full = f"tdicam.{name}"
    if isinstance(obj, types.ModuleType):
        return [f".. automodule:: {obj.__name__}", "   :members:", ""]
    if inspect.isclass(obj):
        kind = "autoexception" if issubclass(obj, BaseException) else "autoclass"
        return [f".. {kind}:: {full}", "   :members:", ""]
    if callable(obj):
        return [f".. autofunction:: {full}", ""]
    return [f".. autodata:: {full}", "   :no-value:", ""]


def api_markdown() -> str:
    """An autosummary table of ``tdicam.__all__``, then a section per name with its autodoc
    entry (in ``__all__``'s order)."""
    import tdicam

    names = list(tdicam.__all__)
    objs = {n: getattr(tdicam, n) for n in names}
    rst = [".. currentmodule:: tdicam", "", ".. autosummary::", "   :nosignatures:", ""]
    rst += [f"   {n}" for n in names if not isinstance(objs[n], types.ModuleType)]
    out = ["```{eval-rst}", *rst, "```", ""]
    mods = [n for n in names if isinstance(objs[n], types.ModuleType)]
    if mods:
        out += ["Modules: " + ", ".join(f"[`tdicam.{n}`](#api-module-{n})" for n in mods) + ".",
                ""]
    for n in names:
        module = isinstance(objs[n], types.ModuleType)
        out += [f"(api-module-{n})=" if module else "", f"## `{'tdicam.' + n if module else n}`",
                "", "```{eval-rst}",
                *_directive(n, objs[n]), "```", ""]
    return "\n".join(out)


_GENERATORS = {"tdicam-blocks": blocks_markdown, "tdicam-scenes": scenes_markdown,
               "tdicam-effects": effects_markdown,
               "tdicam-api": api_markdown}


def _source_read(app, docname, source):
    source[0] = PLACEHOLDER.sub(lambda m: _GENERATORS[m.group(1)](), source[0])


def setup(app):
    app.connect("source-read", _source_read)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
