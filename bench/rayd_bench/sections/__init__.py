"""The sections, in the order they run. Each module has TITLE (one line),
TOOLS (programs it needs besides rayd and python3) and run(ctx), which
returns a dict of settings, every run's raw numbers and a summary."""
from collections import OrderedDict

from . import base, codegrade, converge, embree, equal, http, large, mixed, overload, primitives, scenes, store

SECTIONS = OrderedDict((m.__name__.rsplit(".", 1)[1], m) for m in
                       (scenes, large, embree, primitives, base, http, overload, mixed, converge, equal,
                        store, codegrade))
