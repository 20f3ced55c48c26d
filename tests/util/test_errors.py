"""The jobs' one error line."""

from __future__ import annotations

from rllib_pommer.util.errors import first_sentence, report_error


def test_report_error_prints_one_line_on_stderr_and_returns_the_status(capsys):
    assert report_error(ValueError("--games must be positive")) == 2
    assert report_error("Ray did not start", 1) == 1
    out, err = capsys.readouterr()
    assert out == ""
    assert err == "error: --games must be positive\nerror: Ray did not start\n"


def test_first_sentence_keeps_the_type_and_drops_the_advice():
    exc = RuntimeError("Weights only load failed. Re-running with weights_only=False will...\nmore")
    assert first_sentence(exc) == "RuntimeError: Weights only load failed"
    assert first_sentence(KeyError()) == "KeyError"
