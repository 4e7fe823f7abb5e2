"""Re-export the public names of every module in a subpackage.

Each subpackage's ``__init__`` calls :func:`export_modules` so that a module
added to, say, ``trackcore/models/`` exposes its ``__all__`` as
``trackcore.models.<name>`` without editing a shared ``__init__`` file.  Two
modules exporting the same name is an error, raised at import time.
"""
from __future__ import annotations

import importlib
import pkgutil


def export_modules(package_name: str, package_path, namespace: dict) -> list[str]:
    exported: dict[str, str] = {}
    for info in sorted(pkgutil.iter_modules(package_path), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{package_name}.{info.name}")
        for name in getattr(module, "__all__", ()):
            if name in exported and namespace.get(name) is not getattr(module, name):
                raise ImportError(
                    f"{package_name}: {name!r} is exported by both "
                    f"{exported[name]} and {info.name}")
            exported[name] = info.name
            namespace[name] = getattr(module, name)
    return sorted(exported)
