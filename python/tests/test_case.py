"""Cases from Python: the same schema, defaults and errors as a case file."""

import pickle

import numpy as np
import pytest

import stickslip
from conftest import PAIR_TOML, SOURCE_DIR

FIG10B = SOURCE_DIR / "cases" / "fig10b.toml"


def test_a_dict_and_a_file_with_the_same_values_are_the_same_case():
    from_file = stickslip.Case.from_toml(FIG10B)
    from_dict = stickslip.Case.from_dict({
        "interface": {"contacts": [{"site": [4, 7], "v_star": 4.75e-4},
                                   {"site": [11, 7], "v_star": 2.09e-3}]},
        "drive.velocity": 1e-3,  # dotted keys and sections mix
        "run": {"t_end": 3e-3, "average_from": 1e-3},
        "output": {"interval": 1e-6, "traces": "all"},
    })
    assert from_dict == from_file
    assert from_dict.to_dict()["lattice"] == {"nx": 15, "ny": 15, "nz": 10, "spacing": 1e-4}
    assert from_dict.to_dict() != stickslip.Case.from_dict({}).to_dict()


CASE_FILES = [p for p in sorted((SOURCE_DIR / "cases").glob("*.toml")) if "[sweep]" not in p.read_text()]


@pytest.mark.parametrize("path", CASE_FILES, ids=[p.stem for p in CASE_FILES])
def test_to_toml_reads_back_as_the_same_case(path, tmp_path):
    case = stickslip.Case.from_toml(path)
    written = tmp_path / "case.toml"
    written.write_text(case.to_toml())
    assert stickslip.Case.from_toml(written).to_dict() == case.to_dict()


def test_to_toml_keeps_strings_lists_and_extreme_numbers(tmp_path):
    case = stickslip.Case.from_dict({
        "output": {"dir": 'a "quoted" dir \\ é', "events": [1, 0], "traces": [0]},
        "interface": {"contacts": [{"site": [1, 2], "v_star": 1e-300},
                                   {"site": [4, 2], "v_star": 2.0000000000000004e-3}]},
        "run.t_end": 0.1 + 0.2,
    })
    written = tmp_path / "case.toml"
    written.write_text(case.to_toml())
    back = stickslip.Case.from_toml(written).to_dict()
    assert back["output"]["dir"].endswith('a "quoted" dir \\ é')
    assert back["output"]["events"] == [1, 0]
    assert back["interface"]["contacts"][0]["v_star"] == 1e-300
    assert back["interface"]["contacts"][1]["v_star"] == 2.0000000000000004e-3
    assert back["run"]["t_end"] == 0.1 + 0.2


def test_replace_is_like_set_and_leaves_the_original_alone(pair_file):
    case = stickslip.Case.from_toml(pair_file)
    slower = case.replace({"drive.velocity": 3e-4, "lattice": {"nz": 6}})
    assert slower.to_dict()["drive"]["velocity"] == 3e-4
    assert slower.to_dict()["lattice"]["nz"] == 6
    assert case.to_dict()["drive"]["velocity"] == 1e-3
    # A later change of the same key wins, as a later --set does.
    assert slower.replace({"drive.velocity": 5e-4}).to_dict()["drive"]["velocity"] == 5e-4
    # Values of other types, as TOML takes them.
    assert case.replace({"material.grad_div": "navier", "material.poisson_ratio": 0.25}
                        ).to_dict()["material"]["grad_div"] == "navier"


@pytest.mark.parametrize("changes, message", [
    ({"interface.coverage": 1.5}, "interface.coverage: must be in (0, 1], got 1.5"),
    ({"interface": {"covrage": 0.2}}, "interface.covrage: unknown key 'covrage' (did you mean 'coverage'?)"),
    ({"lattice.nx": 6.5}, "lattice.nx: expected an integer, got floating-point"),
    ({"solver.method": "rk5"}, "solver.method"),
    ({"drive.velocity": None}, "drive.velocity: NoneType is not a case value"),
    ({"interface": 3}, "interface: expected a dict of the section's keys, got int"),
    ({"latice": {"nx": 3}}, "latice.nx: unknown section 'latice'"),
    ({"run.average_from": 2e-3}, "run.average_from: must be in [0, run.t_end = 0.001), got 0.002"),
])
def test_a_bad_key_or_value_raises_case_error_naming_the_key(changes, message, pair_file):
    with pytest.raises(stickslip.CaseError) as caught:
        stickslip.Case.from_toml(pair_file).replace(changes)
    assert message in str(caught.value)
    with pytest.raises(stickslip.CaseError) as caught:
        stickslip.Case.from_dict({**changes, "run.t_end": 1e-3} if "run.average_from" in changes else changes)
    assert message in str(caught.value)
    assert isinstance(caught.value, ValueError)


def test_a_bad_case_file_raises_case_error_with_file_and_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(PAIR_TOML.replace("nz = 4", "nz = -4"))
    with pytest.raises(stickslip.CaseError, match=r"bad.toml:4: lattice.nz: must be >= 2, got -4"):
        stickslip.Case.from_toml(bad)
    with pytest.raises(FileNotFoundError, match="no such case file.*missing.toml"):
        stickslip.Case.from_toml(tmp_path / "missing.toml")
    with pytest.raises(FileNotFoundError):
        stickslip.run(tmp_path / "missing.toml")


def test_tuples_and_numpy_values_are_case_values():
    case = stickslip.Case.from_dict({
        "interface": {"contacts": ({"site": (1, 2), "v_star": np.float64(4.75e-4)},
                                   {"site": np.array([4, 2]), "v_star": np.float32(2.09e-3)})},
        "lattice": {"nx": np.int64(6), "ny": 6, "nz": 4},
        "output": {"traces": (0, 1), "steps": np.bool_(True)},
    })
    d = case.to_dict()
    assert d["interface"]["contacts"] == [{"site": [1, 2], "v_star": 4.75e-4},
                                          {"site": [4, 2], "v_star": 2.09e-3}]  # float32 as written
    assert d["lattice"]["nx"] == 6 and d["output"]["traces"] == [0, 1] and d["output"]["steps"] is True


@pytest.mark.parametrize("changes, message", [
    ({"": 7}, "'': expected a section or section.key"),
    ({"lattice.nx=7 ": 6}, "lattice.nx=7 : unknown key 'nx=7 '"),
    ({"lattice": {"nx = 3, ny": 6}}, "lattice.nx = 3, ny: unknown key"),
    ("lattice.nx=6", "expected a dict of case keys, got str"),
])
def test_key_names_cannot_smuggle_values(changes, message):
    with pytest.raises(stickslip.CaseError) as caught:
        stickslip.Case.from_dict(changes)
    assert message in str(caught.value)


def test_a_case_pickles_as_the_same_case(pair_file):
    for case in (stickslip.Case.from_toml(pair_file).replace({"drive.velocity": 3e-4}),
                 stickslip.Case.from_dict({"lattice.nx": 6})):
        back = pickle.loads(pickle.dumps(case))
        assert back == case and back.source == case.source and back.to_toml() == case.to_toml()


def test_seed_or_coverage_over_explicit_contacts_is_refused_and_repr_shows_the_placed_coverage():
    pair = stickslip.Case.from_toml(FIG10B)  # two contacts on 15x15
    for change in ({"interface.seed": 7}, {"interface.coverage": 0.4}):
        with pytest.raises(stickslip.CaseError, match="interface.contacts lists them"):
            pair.replace(change)
    assert pair.coverage == 2 / 225
    assert "2 contacts listed, coverage 0.008889" in repr(pair)
    random = stickslip.Case.from_dict({"lattice": {"nx": 6, "ny": 6}, "interface.coverage": 0.3})
    assert random.coverage == 11 / 36  # floor(0.3 * 36 + 0.5) contacts
    assert "coverage 0.3056" in repr(random)


def test_a_case_reads_by_section_and_key_as_items_or_attributes(pair_file):
    case = stickslip.Case.from_toml(pair_file)
    assert case["run"]["average_from"] == case.run.average_from == case.to_dict()["run"]["average_from"]
    assert case.lattice.nx == 6 and case["interface"]["contacts"][1]["v_star"] == 2.09e-3
    with pytest.raises(AttributeError, match="read-only"):
        case.run.t_end = 1.0
    with pytest.raises(KeyError, match="no such section"):
        case["runs"]
    with pytest.raises(AttributeError, match="run.t_edn: no such key"):
        case.run.t_edn


def test_replace_takes_keywords_too_and_a_key_given_twice_is_refused(pair_file):
    case = stickslip.Case.from_toml(pair_file)
    assert case.replace(**{"run.t_end": 1e-2}) == case.replace({"run.t_end": 1e-2})
    assert case.replace(run={"t_end": 1e-2}).run.t_end == 1e-2
    with pytest.raises(stickslip.CaseError, match="run.t_end: given twice"):
        case.replace({"run.t_end": 1e-2}, **{"run.t_end": 2e-2})
    # As a TOML file refuses a duplicate key: which one was meant is not known.
    with pytest.raises(stickslip.CaseError, match="lattice.nx: given twice"):
        stickslip.Case.from_dict({"lattice": {"nx": 8}, "lattice.nx": 9})
