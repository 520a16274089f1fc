"""``DesignProblem.chunk``: the batch run as ``lax.map`` over vmapped chunks gives the same objective,
per-case criteria and gradient as one vmap over the whole batch, also when the chunk does not
divide the batch (the last chunk is padded); the "auto" sizes; bad values are refused."""

import dataclasses

import diffrax
import numpy as np
import pytest

from jaxcable.arresting.design import design_problem, objective_and_grad, objective_value, paper_start
from jaxcable.cli.design import design_main
from jaxcable.studies.batching import AUTO_CHUNK, chunk_size

# 5 cases in chunks of 2: three chunks, the last padded with one copy of case 5
SETTINGS = dict(n=5, t_end_s=0.6, rtol=1e-8, atol=1e-8)


@pytest.mark.slow
def test_chunked_batch_equals_the_whole_batch():
    # slow tier: its three compiled gradient programs took 68 s of the default tier's 18.6 min on
    # 2 cores (CI's limit: 20 min); the chunk sizes and the refusals stay in the default tier
    whole = design_problem("m_w,F_f", chunk=None, **SETTINGS)
    chunked = dataclasses.replace(whole, chunk=2)
    u = whole.space.to_unconstrained(paper_start(whole))
    j0, g0, aux0 = objective_and_grad(whole, u)
    j1, g1, aux1 = objective_and_grad(chunked, u)
    # Measured here: equal to 1e-15. Tolerance: the chunks are compiled with another batch shape,
    # and on another CPU the vectorised arithmetic may round differently and shift the adaptive
    # step sequence; the outputs then differ at the integration tolerance (rtol 1e-8 here; 5e-6 in
    # the gradient at n = 32 in chunks of 16 with the default rtol 1e-6).
    np.testing.assert_allclose(float(j1), float(j0), rtol=1e-7)
    np.testing.assert_allclose(np.asarray(g1), np.asarray(g0), rtol=1e-6)
    for group in ("smooth", "hard"):
        for name, v0 in aux0[group].items():
            v1 = np.asarray(aux1[group][name])
            assert v1.shape == (5,), f"{group}.{name}: the padded case must be dropped, got shape {v1.shape}"
            np.testing.assert_allclose(v1, np.asarray(v0), rtol=1e-7, err_msg=f"{group}.{name}")
    np.testing.assert_array_equal(np.asarray(aux1["status"]), np.asarray(aux0["status"]))
    # the forward objective alone (adjoint None) takes the same path
    j2, _ = objective_value(chunked, u)
    np.testing.assert_allclose(float(j2), float(j0), rtol=1e-7)


def test_auto_chunk_sizes():
    p = design_problem("m_w,F_f", n=2, t_end_s=0.2)
    assert p.chunk == "auto"
    assert chunk_size(p.chunk, None) == AUTO_CHUNK["forward"] == 32  # the CPU sizes (tests run on the CPU)
    assert chunk_size(p.chunk, diffrax.ForwardMode()) == AUTO_CHUNK["forward_mode"] == 16
    assert chunk_size(p.chunk, diffrax.RecursiveCheckpointAdjoint()) == AUTO_CHUNK["reverse_mode"] == 32
    assert chunk_size(dataclasses.replace(p, chunk=None).chunk, None) is None
    assert chunk_size(dataclasses.replace(p, chunk=3).chunk, diffrax.ForwardMode()) == 3


@pytest.mark.parametrize("bad", [0, -2, 2.5, True, "big"])
def test_bad_chunk_is_refused(bad):
    with pytest.raises(ValueError, match="chunk"):
        design_problem("m_w,F_f", n=2, t_end_s=0.2, chunk=bad)


@pytest.mark.parametrize("text", ["0", "-3", "lots"])
def test_cli_bad_chunk_is_refused(text, capsys):
    assert design_main(["--n", "2", "--steps", "0", "--chunk", text]) == 2
    assert "chunk" in capsys.readouterr().err
