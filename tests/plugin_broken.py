"""A plug-in module that does not import (the tests' planted failure)."""

raise ImportError("planted: this plug-in's dependency is missing")
