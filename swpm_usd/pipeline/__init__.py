"""The declarative pipeline: ``swpm-pipeline run pipeline.yaml`` (config, rules, run, manifest, report)."""

from .._lazy import lazy_attributes

# imported on first use: the config imports the schema, and ``python -m swpm_usd.pipeline.schema`` would
# find it loaded by the package's import (runpy warns)
__getattr__, __dir__ = lazy_attributes(
    __name__,
    {
        **dict.fromkeys(("Config", "ConfigError", "load_config"), "config"),
        **dict.fromkeys(("RunResult", "SelectionError", "plan", "run"), "runner"),
    },
)

__all__ = ["Config", "ConfigError", "RunResult", "SelectionError", "load_config", "plan", "run"]
