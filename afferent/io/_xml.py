"""One parse of an XML file that an export is made of (.pvd, .pvtu, .vtm, .xdmf).

Every reader parses these through :func:`parse_xml` (the one-parse .vtu reader, afferent.io._vtu,
probes its file itself: a file that is not XML may hold raw appended data), so a file that is not well-formed XML (an
undefined ``&entity;`` in element text, an amplifying entity, a truncated file, bytes that are not
text) is one :class:`~afferent.exceptions.SEDFormatError` naming the file and the kind of file
expected, never the bare ``xml.etree.ElementTree.ParseError`` (issue 33, item 11: a .vtm whose
text holds an entity, which VTK read and the member listing did not).
"""

from __future__ import annotations

from xml.etree import ElementTree as ET

from ..exceptions import SEDFormatError

__all__ = ["parse_xml"]


def parse_xml(path: str, what: str) -> ET.Element:
    """The root element of the XML file ``path``.

    Parameters
    ----------
    path : str
        The file (named in the error).
    what : str
        The kind of file expected, for the error: ``'.vtm'``, ``'XDMF'``.

    Raises
    ------
    SEDFormatError
        ``SED file '...' is not a valid <what> (XML) file: <expat's reason, line, column>``.
    """
    try:
        return ET.parse(path).getroot()
    except ET.ParseError as err:
        raise SEDFormatError(f"SED file {path!r} is not a valid {what} (XML) file: {err}") from err
