"""Show numpydoc's citation references as the docstring wrote them: ``[1]``, not ``[R<hash>-1]``.

numpydoc prefixes each docstring's citations with a hash of the object's name (``[1]_`` becomes
``[R2a8223b450a5-1]_``, so that two docstrings on one page do not collide) and takes the prefix
off the labels again once the page is parsed, finding the references through the citations'
back-references. On these docs' API pages the docstrings are parsed inside MyST's ``{eval-rst}``
blocks, which parse into a document of their own: the references are not registered with the
page, no back-reference is made, and numpydoc leaves every reference in the text reading
``[R<hash>-n]``. This takes the prefix off those references; the link target is unchanged.
"""

import re

from docutils import nodes
from sphinx.addnodes import pending_xref

# numpydoc.numpydoc.rename_references: "R" + the first HASH_LEN (12) hex digits + "-" + label
_PREFIXED = re.compile(r"R[0-9a-f]{12}-(.+)")


def _relabel(app, doctree):
    for ref in doctree.findall(pending_xref):
        if ref.get("refdomain") != "citation":
            continue
        m = _PREFIXED.fullmatch(ref.get("reftarget", ""))
        if m and len(ref.children) == 1 and ref.astext() == f"[{m.group(0)}]":
            label = f"[{m.group(1)}]"
            ref.children[0].replace_self(nodes.inline(label, label))


def setup(app):
    app.connect("doctree-read", _relabel)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
