"""Hide a named list of known warnings, one by one, and fail when an entry hides nothing.

conf.py lists in ``known_warnings`` the warnings the docs build shows today from text it does
not own (docstrings and command-line help written in the packages). Each entry is
``(where, what)``: substrings of the warning's location and message. A warning that matches
an entry is not shown and does not fail ``sphinx-build -W``; every other warning still does.
An entry that matched nothing in a full build is itself a warning: the docstring was fixed, so
remove the entry.
"""

import logging

from sphinx.util import logging as sphinx_logging

logger = sphinx_logging.getLogger(__name__)


def _location(record) -> str:
    loc = getattr(record, "location", None)
    if loc is None:
        return ""
    if isinstance(loc, tuple):
        return ":".join(str(x) for x in loc if x is not None)
    if isinstance(loc, str):
        return loc
    # a docutils node: the source it was parsed from (a docstring names its object there)
    source = getattr(loc, "source", None) or ""
    return f"{source}:{getattr(loc, 'line', '')}"


class KnownWarningFilter(logging.Filter):
    def __init__(self, app):
        super().__init__()
        self.app = app
        self.hits = {}

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno < logging.WARNING or getattr(record, "type", "") == "known_warnings":
            return True     # not a warning, or this extension's own (an entry that hid nothing)
        try:
            message = record.getMessage()
        except (TypeError, ValueError):
            message = str(record.msg)
        where = _location(record)
        text = f"{where} {message}"
        for entry in self.app.config.known_warnings:
            loc, what = entry
            if loc in text and what in message:
                self.hits[entry] = self.hits.get(entry, 0) + 1
                return False
        return True


def _install(app):
    flt = KnownWarningFilter(app)
    app._known_warning_filter = flt
    for handler in logging.getLogger(sphinx_logging.NAMESPACE).handlers:
        if isinstance(handler, sphinx_logging.WarningStreamHandler):
            # first, before Sphinx counts the warning (and before -W's exception, if any)
            handler.filters.insert(0, flt)


def _note_read(app, env, docnames):
    app._known_warnings_full_read = set(docnames) >= set(env.found_docs)


def _report(app, exception):
    if exception is not None or app.builder.name not in {"html", "dirhtml", "singlehtml"}:
        return
    flt = app._known_warning_filter
    if not getattr(app, "_known_warnings_full_read", False):
        return  # an incremental build re-reads only what changed: it cannot tell a stale entry
    for entry in app.config.known_warnings:
        if entry not in flt.hits:
            logger.warning("known_warnings entry %r hid nothing: remove it from docs/conf.py",
                           entry, type="known_warnings")
    hidden = sum(flt.hits.values())
    if hidden:
        logger.info("known_warnings: %d known warnings hidden (docs/conf.py lists them)", hidden)


def setup(app):
    app.add_config_value("known_warnings", [], "env", types=(list, tuple))
    app.connect("builder-inited", _install)
    app.connect("env-before-read-docs", _note_read)
    app.connect("build-finished", _report)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
