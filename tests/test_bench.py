"""``jaxcable bench`` (jaxcable/studies/bench.py, jaxcable/cli/bench.py): the short speed-against-error benchmark.

Runs the cheapest case (the 1-DOF passive model, ~10 s to compile) once per module and checks the
printed table, the JSON and CSV outputs, that the measured error falls as the tolerance tightens,
and the error bookkeeping against an independent reference: the closed-form stop distance of the
1-DOF model (eqs 18-19: E(theta_s) = 0), which involves no time integration.
"""

import csv
import json

import numpy as np
import pytest

from jaxcable.arresting.one_dof import params_groups, stop_distance_bar
from jaxcable.arresting.bench_cases import one_dof_params
from jaxcable.cli.bench import bench_main
from jaxcable.studies.bench import make_bench_case, relative_errors, run_bench

RTOLS = ("1e-3", "1e-5", "1e-7")


@pytest.fixture(scope="module")
def bench_json(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench") / "bench.csv"
    import io
    from contextlib import redirect_stdout

    buf = io.StringIO()
    with redirect_stdout(buf):
        rc = bench_main(["--cases", "1dof", "--rtols", *RTOLS, "--json", "--out", str(out)])
    assert rc == 0
    return json.loads(buf.getvalue()), out


def test_json_keys_and_csv(bench_json):
    result, out = bench_json
    assert {"machine", "precision", "reference", "references", "rows", "total_s"} <= set(result)
    assert result["precision"] == "float64"
    assert {"jax", "processor", "load_average_1_5_15_min"} <= set(result["machine"])
    rows = result["rows"]
    assert [r["rtol"] for r in rows] == [1e-3, 1e-5, 1e-7]
    for r in rows:
        assert {"scene", "level", "solver", "rtol", "wall_s", "error", "errors", "num_steps", "status"} <= set(r)
        assert set(r["errors"]) == {"z_max_m", "a_max_g", "sigma_max_mpa"}
        assert r["status"] == "successful" and r["wall_s"] > 0
    # the reference's first call compiled the solver; the case's first row carries that compile time
    assert result["references"]["1dof"]["compile_s"] > 0 and rows[0]["compile_s"] > 0
    with open(out) as f:
        table = list(csv.DictReader(f))
    assert len(table) == 3 and float(table[2]["rtol"]) == 1e-7
    assert np.isclose(float(table[0]["error"]), rows[0]["error"])


def test_error_falls_with_tolerance(bench_json):
    errs = [r["error"] for r in bench_json[0]["rows"]]
    assert errs[0] > errs[1] > errs[2], errs
    # a tolerance means something in the user's quantities: at rtol 1e-7 the outputs are within 1e-6
    assert errs[2] < 1e-6, errs
    assert errs[0] > 10 * errs[2]


def test_errors_against_closed_form_stop(bench_json):
    """The drop at the stop has a closed form (no time integration): the reference matches it and
    each row's z_max error equals its distance to it (the reference's own error is negligible)."""
    result, _ = bench_json
    params = one_dof_params()
    _, F_t_bar, v0_bar = params_groups(params)
    z_exact = float(stop_distance_bar(F_t_bar, v0_bar) * params.l_0)
    ref = result["references"]["1dof"]
    assert abs(ref["z_max_m"] - z_exact) / z_exact < 1e-9
    for r in result["rows"]:
        direct = abs(r["z_max_m"] - z_exact) / z_exact
        assert np.isclose(r["errors"]["z_max_m"], direct, rtol=1e-2, atol=2e-10)


def test_table_printed(capsys, bench_json):
    # compiled code is reused from the fixture's run: only the runs are paid here
    assert bench_main(["--cases", "1dof", "--rtols", "1e-4", "-q"]) == 0
    text = capsys.readouterr().out
    assert "jaxcable bench" in text and "JAX" in text and "float64" in text
    header = next(line for line in text.splitlines() if line.startswith("scene"))
    for col in ("level", "solver", "rtol", "wall [s]", "error vs ref", "steps"):
        assert col in header
    assert "passive" in text and "1dof" in text and "tsit5" in text


def test_bad_input():
    with pytest.raises(ValueError, match="level"):
        make_bench_case("passive", "segments")
    with pytest.raises(ValueError, match="scene"):
        make_bench_case("orbit", "rigid")
    with pytest.raises(ValueError, match="t_end_s"):
        make_bench_case("passive", "rigid", t_end_s=-1.0)
    with pytest.raises(ValueError, match="bench case"):
        run_bench(("moon",))
    with pytest.raises(ValueError, match="rtol"):
        run_bench(("1dof",), rtols=(0.0,))


def test_relative_errors_nan_on_failure():
    errs = relative_errors({"a": float("nan"), "b": 1.1}, {"a": 1.0, "b": 1.0}, ("a", "b"))
    assert np.isnan(errs["a"]) and np.isnan(errs["max"]) and np.isclose(errs["b"], 0.1)
