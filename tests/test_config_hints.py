"""A misspelt key or value of a pipeline config names the closest right one (``did you mean``), beside the
line and column it already gave (helper-196's audit: ``vanila``, ``optimise_connectivity``)."""

from __future__ import annotations

import pytest

from swpm_usd.pipeline import ConfigError, load_config

BASE = """\
version: 1
assets:
  - glob: "meshes/*.obj"
output:
  dir: out
"""


def _problems(tmp_path, text: str) -> str:
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_config(cfg)
    return str(info.value)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (BASE + "defaults:\n  encoding: vanila\n", "defaults.encoding: 'vanila' is not one of"),
        (BASE + "rules:\n  - name: r\n    encoding: Sliding_Window\n", "did you mean 'sliding-window'?"),
        (
            BASE + "defaults:\n  encoding: sliding-window\n  params: {optimise_connectivity: true}\n",
            "optimise_connectivity: unknown key (not a parameter of sliding-window); did you mean "
            "'optimize_connectivity'?",
        ),
        (BASE.replace("assets:", "asset:") + "assets: []\n", "$.asset: unknown key; did you mean 'assets'?"),
        (
            BASE + "defaults:\n  encoding: vanilla\n  params: {seam_wieght: 2}\n",
            "did you mean 'seam_weight'?",
        ),
    ],
)
def test_a_misspelt_key_or_value_names_the_closest_right_one(tmp_path, text, expected):
    assert expected in _problems(tmp_path, text)


@pytest.mark.parametrize(
    ("params", "flag", "said"),
    [
        (
            "{MU: 0.2}",
            ["-p", "MU=0.2"],
            "(not a parameter of vanilla); did you mean 'mu'? sliding-window takes it",
        ),
        (
            "{optimise_connectivity: true}",
            ["-e", "skip-strip", "-p", "optimise_connectivity=true"],
            "(not a parameter of skip-strip); did you mean 'optimize_connectivity'? sliding-window takes it",
        ),
    ],
)
def test_a_slip_on_another_encodings_name_is_named_as_p_names_it(tmp_path, params, flag, said):
    """A config's ``params`` key that is a slip on another encoding's parameter names it and who takes it, as
    ``-p`` and :func:`swpm_usd.build` do (the config said only "not a parameter of vanilla" of ``MU``)."""
    from click.testing import CliRunner

    from swpm_usd.cli import main

    encoding = flag[1] if flag[0] == "-e" else "vanilla"
    problems = _problems(tmp_path, BASE + f"defaults:\n  encoding: {encoding}\n  params: {params}\n")
    assert said in problems
    mesh = tmp_path / "t.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    result = CliRunner().invoke(main, ["build", str(mesh), *flag])
    meant = said.split("); ", 1)[1]
    assert result.exit_code == 2 and meant in result.output, result.output


def test_a_key_yaml_reads_as_no_string_gets_no_guess(tmp_path):
    """A ``params`` key YAML reads as a number is reported without a guess (and without a crash)."""
    problems = _problems(tmp_path, BASE + "defaults:\n  encoding: vanilla\n  params: {1: 2}\n")
    assert "did you mean" not in problems


def test_the_enum_hint_is_the_closest_value(tmp_path):
    assert "did you mean 'vanilla'?" in _problems(tmp_path, BASE + "defaults:\n  encoding: vanila\n")


@pytest.mark.parametrize(
    "text",
    [
        BASE + "defaults:\n  encoding: quadric\n",  # (nothing close: no guess)
        BASE + "defaults:\n  encoding: vanilla\n  params: {mu: 0.2}\n",  # (another encoding's parameter)
        BASE + "colour: red\n",
    ],
)
def test_no_guess_when_nothing_is_close(tmp_path, text):
    problems = _problems(tmp_path, text)
    assert "did you mean" not in problems
