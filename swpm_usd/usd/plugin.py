"""Register the SwpmMeshAPI schema plugin with usd-core (imported by ``import swpm_usd``).

USD only learns a plugin's schemas if it is registered before the first stage or schema-registry use in the
process, so ``swpm_usd/__init__.py`` imports this module first. Only ``pxr.Plug`` is imported here.
Other USD applications (usdview, DCCs) find the schema through the environment, set before they start::

    export PXR_PLUGINPATH_NAME=$(python -c "import swpm_usd.usd.plugin as p; print(p.PLUGIN_PATH)")

A stage opened without the plugin still reads: every value is authored explicitly.
"""

from __future__ import annotations

from pathlib import Path

PLUGIN_PATH = str(Path(__file__).resolve().parent / "resources")
_registered: bool | None = None


def register() -> bool:
    """Register the plugin once; True when SwpmMeshAPI is a known schema type afterwards."""
    global _registered
    if _registered is None:
        try:
            from pxr import Plug

            Plug.Registry().RegisterPlugins(PLUGIN_PATH)
            _registered = True
        except Exception:  # pragma: no cover - usd-core missing or broken: the writer still works
            _registered = False
    return _registered


register()
