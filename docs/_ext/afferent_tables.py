"""Tables of the documentation generated from the code, so they cannot drift from it.

``.. afferent-table:: NAME`` (MyST: ````{afferent-table} NAME````) inserts one of

- ``presets``: :data:`afferent.strain_energy.PRESETS` (component order, shear, source note);
- ``sed-names``: the SED array names ``read_sed`` recognises, in order of preference;
- ``energy-names``: the element *energy* names it refuses, with the hint it gives;
- ``units``: the unit names accepted for lengths, SED/stress and times;
- ``scene-keys``: every table and key of a scene file (:mod:`afferent.scene`), its type,
  default, choices and accepted unit suffixes.

It reads the package's plain-text docstrings as they are written: ``|x|`` is an absolute value
and ``lambda_`` a Python name, not a reST substitution or hyperlink reference (see
:func:`_plain_text`). It also works around a Sphinx autosummary bug: ``extract_summary`` cuts the first sentence
at a period inside an inline literal (``coef . chi``), leaving an unterminated literal in
the summary table; the summary is extended to the next sentence end outside a literal.
"""

from __future__ import annotations

import re
from dataclasses import fields

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.ext import autosummary
from sphinx.util.docutils import SphinxDirective


# ---------------------------------------------------------------- autosummary summaries
_extract_summary = autosummary.extract_summary
_SENTENCE_END = re.compile(r"\.(?:\s+|$)")


def _extract_summary_outside_literals(doc, settings):
    summary = _extract_summary(doc, settings)
    if summary.count("``") % 2 == 0:
        return summary
    stanza = []
    for line in doc:
        if not line.strip():
            if stanza:
                break
            continue
        stanza.append(line.strip())
    text = " ".join(stanza)
    for m in _SENTENCE_END.finditer(text):
        candidate = text[: m.start() + 1]
        if len(candidate) > len(summary) and candidate.count("``") % 2 == 0:
            return candidate
    return text


autosummary.extract_summary = _extract_summary_outside_literals


# ------------------------------------------------------------------ plain-text docstrings
# The docstrings are written to be read in ``help()`` as well as here, with equations in plain
# text: ``|x|`` (absolute value) and names ending in an underscore (``lambda_``). reST reads the
# first as a substitution and the second as a hyperlink reference, both undefined (errors).
# The package defines neither, so outside inline literals, roles, math and literal/directive
# blocks, the two are escaped to render as written.
_INLINE = re.compile(r"(``.+?``|:[\w:+.-]+:`[^`]*`|`[^`]*`_{0,2}|\*\*[^*\n]+\*\*)")
_SUBSTITUTION = re.compile(r"(?<![\w\\])\|(?=\S)([^|\n]*?\S)\|(?!\w)")
_NAME_REFERENCE = re.compile(r"\b([A-Za-z]\w*?)_(?=$|[\s.,;:!?)\]}'\"])")


def _escape_plain(text: str) -> str:
    parts = _INLINE.split(text)
    for i in range(0, len(parts), 2):  # even items are outside inline markup
        parts[i] = _NAME_REFERENCE.sub(r"\1\\_", _SUBSTITUTION.sub(r"\\|\1\\|", parts[i]))
    return "".join(parts)


def _plain_text(app, what, name, obj, options, lines):
    """Escape ``|x|`` and ``name_`` in a docstring (after numpydoc has formatted it)."""
    block_indent = None  # indentation of a line ending in '::' (literal block or directive)
    doctest = False
    for i, line in enumerate(lines):
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if block_indent is not None:
            if not stripped or indent > block_indent:
                continue
            block_indent = None
        if doctest:
            if stripped:
                continue
            doctest = False
        if stripped.startswith(">>>"):
            doctest = True
            continue
        if stripped.endswith("::"):
            block_indent = indent
        if stripped.startswith(".. "):
            continue
        lines[i] = _escape_plain(line)


# ------------------------------------------------------------------------------- tables
def _lit(value) -> str:
    return f"``{value}``"


def _list_table(header: list[str], rows: list[list[str]], widths: str | None = None) -> list[str]:
    """A list-table in reST syntax; :func:`_as_myst` rewrites it for Markdown (MyST) pages."""
    out = [".. list-table::", "   :header-rows: 1"]
    if widths:
        out.append(f"   :widths: {widths}")
    out.append("")
    for row in [header, *rows]:
        for i, cell in enumerate(row):
            out.append(("   * - " if i == 0 else "     - ") + (cell if cell else " "))
    return out


def _as_myst(lines: list[str]) -> list[str]:
    """The same content for a MyST page: fenced directive, ``{role}`` instead of ``:role:``."""
    out = []
    in_table = False
    for line in lines:
        line = re.sub(r"(?<![\w`]):(\w+):`", r"{\1}`", line)
        if line.startswith(".. list-table::"):
            out.append("````{list-table}")
            in_table = True
        elif in_table and line.startswith("   :"):
            out.append(line.strip())
        elif in_table and line.startswith("   "):
            out.append(line[3:])
        elif in_table and not line.strip():
            continue
        else:
            out.append(line)
    if in_table:
        out.append("````")
    return out


def _presets() -> list[str]:
    from afferent.strain_energy import PRESETS

    rows = [[_lit(name), " ".join(c.order), c.shear, c.note] for name, c in PRESETS.items()]
    return _list_table(["``--preset``", "order of a 6-component array", "strain shear", "source (status)"], rows,
                       "14 30 12 44")


def _sed_names() -> list[str]:
    from afferent.io._columns import SED_ALIASES

    return [", ".join(_lit(n) for n in SED_ALIASES)]


def _energy_names() -> list[str]:
    from afferent.io._columns import ENERGY_NOT_DENSITY

    rows = [[_lit(k), v] for k, v in ENERGY_NOT_DENSITY.items()]
    return _list_table(["name (canonical)", "why it is refused"], rows, "25 75")


def _units() -> list[str]:
    from afferent.units import LENGTH_UNITS, SED_UNITS, TIME_UNITS

    def fmt(table):
        return ", ".join(f"{_lit(k)} ({v:g})" for k, v in table.items())

    rows = [["length (to m)", fmt(LENGTH_UNITS)], ["SED, stress (to Pa = J/m^3)", fmt(SED_UNITS)],
            ["time (to s)", fmt(TIME_UNITS)]]
    return _list_table(["quantity", "accepted names (factor to SI)"], rows, "25 75")


def _scene_keys() -> list[str]:
    from afferent.scene import schema as scene  # the schema tables (private names: docs generation only)

    quantities = scene._QUANTITIES
    rows = []
    for table, (_attr, cls) in scene._TABLES.items():
        for f in fields(cls):
            meta = f.metadata
            q = meta.get("quantity")
            if q:
                si, units = quantities[q]
                base = f.name[: -len(si) - 1]
                key = " / ".join(_lit(f"{base}_{s}") for s in units)
            else:
                key = _lit(f.name)
            if meta.get("aliases"):
                key += " (or " + ", ".join(_lit(a) for a in meta["aliases"]) + ")"
            kind = meta.get("kind", "")
            if meta.get("choices"):
                kind += ": " + ", ".join(_lit(c) for c in meta["choices"])
            value = meta.get("default")
            if value is None and table == "stimulus":
                value = scene._RAMP_DEFAULTS.get(f.name)  # SI; the ramp's defaults (the study's)
                default = "" if value is None else _lit(repr(value).replace("'", '"')) + " (ramp, SI)"
            else:
                if value is None and table == "receptors":
                    value = scene._GRID_DEFAULTS.get(f.name)
                default = "" if value is None else _lit(repr(value).replace("'", '"'))
            rows.append([f"``[{table}]``", key, kind, default, meta.get("doc", "")])
    return _list_table(["table", "key", "type", "default", "note"], rows, "12 28 30 12 18")


def _top_level() -> list[str]:
    import afferent

    rows = [[_lit(f"afferent.{name}"), f":obj:`{module}.{name}`"] for name, module in sorted(afferent._LAZY.items())]
    return _list_table(["name", "defined in"], rows, "40 60")


TABLES = {"top-level": _top_level, "presets": _presets, "sed-names": _sed_names, "energy-names": _energy_names, "units": _units,
          "scene-keys": _scene_keys}


class AfferentTable(SphinxDirective):
    required_arguments = 1
    has_content = False

    def run(self):
        name = self.arguments[0]
        if name not in TABLES:
            raise self.error(f"afferent-table: unknown table {name!r}; pick one of {', '.join(TABLES)}.")
        container = nodes.container()
        text = TABLES[name]()
        if self.env.doc2path(self.env.docname).suffix == ".md":
            text = _as_myst(text)
        lines = StringList(text, source=f"<afferent-table {name}>")
        self.state.nested_parse(lines, self.content_offset, container)
        return container.children


# ------------------------------------------------------------- cross-reference fallbacks
def _resolve_missing(app, env, node, contnode):
    """Resolve two kinds of reference the docstrings use that Sphinx cannot resolve alone.

    - ``afferent.read_sed`` and the other top-level names: ``afferent`` re-exports them
      lazily (PEP 562), so they are documented at their defining module
      (``afferent.io.read_sed``); the reference is pointed there.
    - A bare or partial name (``SEDField``, ``SpikeTrains.rates``) written in a module other
      than the one defining it: resolved when exactly one documented object ends with it.
    """
    if node.get("refdomain") != "py":
        return None
    import afferent

    target = node.get("reftarget", "")
    domain = env.get_domain("py")
    parts = target.split(".")
    if len(parts) == 2 and parts[0] == "afferent" and parts[1] in afferent._LAZY:
        target = f"{afferent._LAZY[parts[1]]}.{parts[1]}"
    else:
        suffix = "." + target.lstrip(".~")
        matches = [name for name in domain.objects if name.endswith(suffix)]
        if len(matches) != 1:
            return None
        target = matches[0]
    return domain.resolve_xref(env, node.get("refdoc"), app.builder, node.get("reftype"), target, node, contnode)


def setup(app):
    app.add_directive("afferent-table", AfferentTable)
    app.connect("missing-reference", _resolve_missing)
    app.connect("autodoc-process-docstring", _plain_text, priority=600)  # after numpydoc (500)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
