"""The declarative pipeline: ``swpm-pipeline run pipeline.yaml`` (config, rules, run, manifest, report)."""

from .config import Config, ConfigError, load_config
from .runner import RunResult, SelectionError, plan, run

__all__ = ["Config", "ConfigError", "RunResult", "SelectionError", "load_config", "plan", "run"]
