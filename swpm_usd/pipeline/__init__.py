"""The declarative pipeline: ``swpm-pipeline run pipeline.yaml`` (config, rules, run, manifest, report)."""

from .config import Config, ConfigError, load_config
from .runner import RunResult, plan, run

__all__ = ["Config", "ConfigError", "RunResult", "load_config", "plan", "run"]
