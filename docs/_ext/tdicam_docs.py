"""Parts of the tdicam docs generated from the code, kept in the Markdown pages themselves.

Five pages hold a generated region, between ``<!-- generated NAME: ... -->`` and
``<!-- end NAME -->``, whose plain Markdown is made from the package (so the page reads on its
own, without Sphinx, and cannot fall behind the code: ``python docs/_ext/tdicam_docs.py``
rewrites the regions, ``--check`` says which are stale, and tests/test_docs.py fails on one):

* ``tdicam-blocks`` (``guide/blocks.md``): the block registry (:mod:`tdicam.blocks`) — an
  overview table, then per block its summary, parameters with ranges and defaults, the
  latency of its Verilog top at the default parameters, its inputs, its ``[pipeline.<block>]``
  scene section and its golden cases;
* ``tdicam-scenes`` (``guide/scenes.md``): the bundled scene and sweep files, each with
  the first paragraph of its leading comment;
* ``tdicam-effects`` (``guide/run.md``): the scene simulator's effects table
  (:data:`tdicam.engine.effects.EFFECTS`), in the order they are applied;
* ``tdicam-registers`` (``guide/registers.md``): the orbit chain's register reference, as
  ``tdicam verilog pipeline --csr`` writes it (``peakrdl-markdown``), its headings one level
  down;
* ``tdicam-api`` (``api.md``): every name in ``tdicam.__all__`` with its signature and
  docstring (a class with its public members, a module with its own ``__all__``).

When Sphinx builds the site, this extension replaces the API region by autodoc entries (an
autosummary table and the cross-referenced entry of every public name); the other regions are
read as they are.
"""

from __future__ import annotations

import inspect
import re
import types
from pathlib import Path

#: A generated region of a page: its opening marker, its Markdown, its closing marker.
REGION = re.compile(r"(<!-- generated (tdicam-[a-z]+):[^\n]*-->\n)(.*?)(<!-- end \2 -->)", re.S)
#: The page (under docs/) that holds each generated region.
PAGES = {"tdicam-blocks": "guide/blocks.md", "tdicam-scenes": "guide/scenes.md",
         "tdicam-effects": "guide/run.md", "tdicam-api": "api.md",
         "tdicam-registers": "guide/registers.md"}
DOCS = Path(__file__).resolve().parents[1]
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
        if b.streams.to_beats is not None:
            facts.append(f"**Co-simulation**: as a stream against its golden model "
                         f"(`tdicam sim {b.name}`); main input `{b.streams.stream}`.")
        else:
            facts.append("**Co-simulation**: not a video stream; its own cocotb test "
                         f"(`cocotb_tests/test_{b.name}.py`).")
        for s in b.streams.side_inputs:
            facts.append(f"**Side input** `{s.name}` (per {s.per}): {_cell(s.what)}")
        if b.pipeline is not None and b.pipeline.options is not None:
            facts.append(f"**Scene section**: `[pipeline.{b.name}]` "
                         f"([scene reference](../scene-format.md)).")
        elif b.pipeline is not None:
            from tdicam.scene.schema import BLOCKS
            facts.append("**Pipeline**: can be named in a scene's `[pipeline].blocks`."
                         if b.name in BLOCKS else
                         "**Pipeline**: the chain builds it in another block's place (a "
                         "`[pipeline.<block>]` memory setting, or the sensor's lanes); "
                         "not named in `[pipeline].blocks`.")
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
    out = ["", "```{eval-rst}", *rst, "```", ""]
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


class _Shown(str):
    """An annotation as written (``from __future__ import annotations`` keeps it a string:
    shown without quotes)."""

    def __repr__(self):
        return str(self)


def _signature(obj) -> str:
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return "(...)"

    def shown(a):
        return _Shown(a) if isinstance(a, str) else a
    params = [p.replace(annotation=shown(p.annotation)) for p in sig.parameters.values()
              if p.name != "self"]
    return str(sig.replace(parameters=params, return_annotation=shown(sig.return_annotation)))


def _doc_block(obj) -> list[str]:
    doc = inspect.getdoc(obj) or ""
    return ["```text", *doc.splitlines(), "```", ""] if doc else [""]


def _members(cls):
    """Public methods and properties defined on ``cls`` (definition order)."""
    for name, value in vars(cls).items():
        if name.startswith("_"):
            continue
        if isinstance(value, (classmethod, staticmethod)):
            yield name, getattr(cls, name), "method"
        elif isinstance(value, property):
            yield name, value, "property"
        elif inspect.isfunction(value):
            yield name, value, "method"


def _anchor(name, obj) -> str:
    """A public name's anchor (by kind: ``Plan`` the class and ``plan`` the function differ
    only in case, which anchors ignore)."""
    kind = ("module" if isinstance(obj, types.ModuleType) else "class" if inspect.isclass(obj)
            else "func")
    return f"api-{kind}-{name.lower()}"


def api_text_markdown() -> str:
    """Every name of ``tdicam.__all__`` as plain Markdown: its signature and docstring (a
    class with its public methods and properties, a module with the names of its own
    ``__all__``), in ``__all__``'s order."""
    import tdicam

    out = ["| name | what it is |", "|---|---|"]
    objs = {n: getattr(tdicam, n) for n in tdicam.__all__}
    for n, obj in objs.items():
        first = (inspect.getdoc(obj) or "").split("\n\n")[0]
        shown = f"tdicam.{n}" if isinstance(obj, types.ModuleType) else n
        out.append(f"| [`{shown}`](#{_anchor(n, obj)}) | {_cell(first)} |")
    out.append("")
    for n, obj in objs.items():
        out.append(f"({_anchor(n, obj)})=")
        if isinstance(obj, types.ModuleType):
            out += [f"## `tdicam.{n}`", "", *_doc_block(obj)]
            for m in getattr(obj, "__all__", ()):
                f = getattr(obj, m)
                if inspect.isclass(f):
                    out += [f"### `tdicam.{n}.{m}`", "", *_doc_block(f)]
                    for mn, mv, kind in _members(f):
                        sig = "" if kind == "property" else _signature(mv)
                        out += [f"#### `{m}.{mn}{sig}`", "", *_doc_block(mv)]
                elif callable(f):
                    out += [f"### `tdicam.{n}.{m}{_signature(f)}`", "", *_doc_block(f)]
        elif inspect.isclass(obj):
            kind = "exception" if issubclass(obj, BaseException) else "class"
            out += [f"## `{n}` ({kind})", "", *_doc_block(obj)]
            if kind == "class":
                for mn, mv, what in _members(obj):
                    sig = "" if what == "property" else _signature(mv)
                    out += [f"### `{n}.{mn}{sig}`", "", *_doc_block(mv)]
        else:
            out += [f"## `{n}{_signature(obj)}`", "", *_doc_block(obj)]
    return "\n".join(out).rstrip() + "\n"


#: What each region holds (plain Markdown).
def registers_markdown() -> str:
    """The orbit chain's register reference (:func:`tdicam.chain.registers.markdown`), its
    headings one level down (under the page's own)."""
    import warnings
    from tdicam.chain import design, registers
    p = design.chain_plan(design.load_pipeline_scene(SCENES / "orbit_chain.toml"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        text = registers.markdown(registers.compile_rdl(registers.rdl_text(
            design.register_map(p))))
    text = re.sub(r"^(#+) ", r"#\1 ", text.split("-->", 1)[1].strip(), flags=re.M)
    return text + "\n"


_GENERATORS = {"tdicam-blocks": blocks_markdown, "tdicam-scenes": scenes_markdown,
               "tdicam-effects": effects_markdown, "tdicam-api": api_text_markdown,
               "tdicam-registers": registers_markdown}
#: What Sphinx shows instead, where it differs (autodoc).
_SPHINX = {"tdicam-api": api_markdown}


def regions(text):
    """``{name: (start, end, body)}`` of the generated regions of a page's ``text``."""
    return {m.group(2): (m.start(3), m.end(3), m.group(3)) for m in REGION.finditer(text)}


def update(check=False, names=None) -> list[str]:
    """Rewrite every generated region (or, with ``check``, only say which are stale);
    returns the pages (relative to docs/) that were or would be changed."""
    stale = []
    for name, page in PAGES.items():
        if names is not None and name not in names:
            continue
        path = DOCS / page
        text = path.read_text()
        found = regions(text)
        if name not in found:
            raise SystemExit(f"{page}: no generated region {name} (<!-- generated {name}: "
                             f"... --> ... <!-- end {name} -->)")
        start, end, body = found[name]
        new = _GENERATORS[name]()
        if new != body:
            stale.append(page)
            if not check:
                path.write_text(text[:start] + new + text[end:])
    return stale


def _source_read(app, docname, source):
    def sub(m):
        name = m.group(2)
        return m.group(1) + (_SPHINX[name]() if name in _SPHINX else m.group(3)) + m.group(4)
    source[0] = REGION.sub(sub, source[0])


def setup(app):
    app.connect("source-read", _source_read)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}


def main(argv=None) -> int:
    """``python docs/_ext/tdicam_docs.py [--check]``: rewrite the generated regions (exit 0),
    or with ``--check`` list the stale pages (exit 1 when there is one)."""
    import sys
    argv = sys.argv[1:] if argv is None else argv
    check = "--check" in argv
    stale = update(check=check)
    for page in stale:
        print(f"docs/{page}: {'stale' if check else 'rewritten'}")
    return 1 if check and stale else 0


if __name__ == "__main__":
    raise SystemExit(main())
