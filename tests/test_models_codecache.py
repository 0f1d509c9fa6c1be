"""The disk cache of generated stratum functions: same numbers, silent when it cannot help."""

from __future__ import annotations

import json

import numpy as np
import pytest

from stratcli.models import codecache
from stratcli.models.presets import one_arm, two_arm


@pytest.fixture
def cache_home(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    return tmp_path / "stratplan"


def _values(cs, q):
    """Everything a compiled stratum evaluates, at points q."""
    out = [cs.C_explicit, cs.G(q), cs.dG(q)]
    if cs.quadrature_terms is not None:
        out.extend(cs.quadrature_terms(q, 2))
    return out


@pytest.mark.parametrize("build, stratum", [(one_arm, "S3"), (two_arm, "S13")])
def test_a_cached_stratum_gives_the_very_same_numbers(cache_home, build, stratum):
    q = np.random.default_rng(1).uniform(-3, 3, (7, build().n))
    fresh = build().compiled(stratum)
    expected = _values(fresh, q)
    assert len(list(cache_home.glob("*.json"))) == 1  # written, G and dG included
    cached = build().compiled(stratum)  # a new System: read back, nothing differentiated
    assert cached.quadrature_terms is not None and cached.explicit == fresh.explicit
    for a, b in zip(expected, _values(cached, q), strict=True):
        assert np.array_equal(a, b)


def test_an_unwritable_cache_compiles_in_silence(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker))
    cs = one_arm().compiled("S1")
    assert cs.supports_quadrature and cs.G(np.zeros(4)).shape == (4, 2)


def test_a_damaged_entry_is_generated_again(cache_home):
    one_arm().compiled("S2")
    (entry,) = cache_home.glob("*.json")
    entry.write_text(json.dumps({"format": codecache.FORMAT, "explicit": "garbage"}))
    cs = one_arm().compiled("S2")
    q = np.full((1, 4), 0.3)
    assert np.array_equal(cs.quadrature_terms(q, 0)[0], one_arm().compiled("S2").G(q)[:, 3:, :])


def test_the_key_follows_the_fields(cache_home):
    a, b = one_arm(), one_arm()
    s = a.strata["S1"]
    assert codecache.key("one-arm", a.states, "S1", a.fields_on(s)) == codecache.key(
        "one-arm", b.states, "S1", b.fields_on(s)
    )
    assert codecache.key("one-arm", a.states, "S1", a.fields_on(s)) != codecache.key(
        "one-arm", a.states, "S1", a.fields_on(a.strata["S2"])
    )


def test_a_preset_read_from_the_cache_equals_its_printed_equations(cache_home):
    """The identity key finds the entry without the fields; the functions restored from it
    agree with the fields built from the printed equations (eq. 10-13) at random points."""
    import sympy as sp

    from stratcli.models.generated import ArrayFunction

    two_arm().compiled("S24")  # warms the cache
    system = two_arm()
    cached = system.compiled("S24")
    assert system._fields is None  # nothing symbolic was built to find it
    q = np.random.default_rng(2).uniform(-3, 3, (9, system.n))
    G = system.fields_on(system.strata["S24"])
    reference = ArrayFunction(G, list(system.symbols))(q)
    np.testing.assert_allclose(cached.G(q), reference, rtol=1e-13, atol=1e-14)
    assert cached.quadrature == (4,)
    assert isinstance(G, sp.MatrixBase)


def test_a_cached_bracket_basis_equals_the_derived_one(cache_home):
    """Degree-3 brackets of a preset: derived with sympy once, then read back."""
    from stratcli.liealgebra import lie_basis

    q = np.random.default_rng(5).uniform(-3, 3, (6, 4))
    derived = lie_basis(one_arm(), "S2", 3)
    cached = lie_basis(one_arm(), "S2", 3)  # a new System: from the cache
    assert derived.symbolic is not None and cached.symbolic is None
    assert cached.labels == derived.labels
    assert np.array_equal(cached.evaluate(q), derived.evaluate(q))


@pytest.mark.parametrize("strata, degree", [(("S1",), 2), (("S12", "S34"), 3)])
def test_a_cached_closure_across_strata_equals_the_symbolic_one(cache_home, strata, degree):
    """A preset's closure across strata (the check of a two-arm plan, eq. 2): derived with
    sympy once, then read back by a new system with nothing symbolic built."""
    from stratcli.crossbasis import cross_basis, symbolic_cross_basis

    q = np.random.default_rng(7).uniform(-np.pi, np.pi, (25, 5))
    derived = cross_basis(two_arm(), strata, degree)
    assert len(list(cache_home.glob("*.json"))) == 1
    system = two_arm()
    cached = cross_basis(system, strata, degree)  # from the cache
    assert system._fields is None  # no sympy: the fields were never built
    reference = symbolic_cross_basis(two_arm(), strata, degree)
    assert cached.labels == derived.labels == reference.labels
    assert any(label.startswith("[") for label in cached.labels)  # brackets across strata
    np.testing.assert_allclose(cached.evaluate(q), reference.evaluate(q), rtol=0, atol=1e-12)
    assert np.array_equal(cached.evaluate(q), derived.evaluate(q))


def test_an_unwritable_cache_derives_the_closure_across_strata(tmp_path, monkeypatch):
    from stratcli.crossbasis import cross_basis, symbolic_cross_basis

    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker))
    q = np.random.default_rng(8).uniform(-np.pi, np.pi, (5, 5))
    got = cross_basis(two_arm(), ("S1", "S2"), 2)
    expected = symbolic_cross_basis(two_arm(), ("S1", "S2"), 2)
    assert got.labels == expected.labels
    np.testing.assert_allclose(got.evaluate(q), expected.evaluate(q), rtol=0, atol=1e-12)


def test_a_damaged_closure_entry_is_derived_again(cache_home):
    from stratcli.crossbasis import cross_basis

    q = np.random.default_rng(9).uniform(-np.pi, np.pi, (5, 5))
    expected = cross_basis(two_arm(), ("S1",), 2)
    (entry,) = cache_home.glob("*.json")
    entry.write_text(json.dumps({"format": codecache.FORMAT, "labels": ["u2@S1"], "rows": {}}))
    got = cross_basis(two_arm(), ("S1",), 2)
    assert got.labels == expected.labels
    assert np.array_equal(got.evaluate(q), expected.evaluate(q))
    assert json.loads(entry.read_text())["labels"] == expected.labels  # written again
