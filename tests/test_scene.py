"""Tests of the scene files (ngs_driver.scene)."""

import json

import pytest

from ngs_driver.scene import (load_scene, list_scenes, parse_override, from_dict,
                              Scene, SCENE_DIR)


def test_shipped_scenes_load():
    names = list_scenes()
    assert {"koyna", "koyna_classic", "small"} <= set(names)
    s = load_scene("koyna")
    assert s.materials.dam.E == 50e9 and s.materials.rock.rho == 2800.0
    assert s.loads.reservoir_level == 92.0 and s.time.dt == 0.002
    assert s.interface.sigma_max == 3e6 and s.interface.friction == 0.3
    c = load_scene("koyna_classic")
    assert c.geometry.foundation == "rigid" and c.materials.dam.rho == 2643.0
    assert c.materials.rock.E == 50e9          # defaults fill the missing tables
    json.dumps(s.to_dict())                    # summary.json-serialisable


def test_load_by_path(tmp_path):
    p = tmp_path / "x.toml"
    p.write_text('[mesh]\nh_heel = 0.2\n')
    s = load_scene(p)
    assert s.mesh.h_heel == 0.2 and s.name == "x"


def test_frozen():
    s = load_scene("koyna")
    with pytest.raises(Exception):
        s.mesh.h_heel = 1.0


def test_overrides():
    s = load_scene("koyna", ["geometry.foundation=rigid", "mesh.order=2",
                             "damping.frequencies=[2.0, 8.0]", "materials.dam.E=3.1027e10",
                             'output.dir="x/y"', "mesh.lumped_mass=true"])
    assert s.geometry.foundation == "rigid" and s.mesh.order == 2
    assert s.damping.frequencies == (2.0, 8.0) and s.materials.dam.E == 3.1027e10
    assert s.output.dir == "x/y" and s.mesh.lumped_mass is True
    assert parse_override("a.b=1e9") == (["a", "b"], 1e9)
    assert parse_override("a.b=rigid") == (["a", "b"], "rigid")   # bare word -> string
    # an int is accepted where a float is expected
    assert load_scene("koyna", ["materials.dam.E=50000000000"]).materials.dam.E == 5e10


@pytest.mark.parametrize("bad, words", [
    (["mesh.hheel=1"], ["mesh.hheel", "h_heel"]),                  # unknown key (lists allowed)
    (["nosuch.key=1"], ["nosuch", "allowed"]),                     # unknown section
    (["mesh.h_heel.x=1"], ["not a table"]),                        # bad --set path
    (["mesh=1"], ["is a table"]),
    (["a..b=1"], ["bad key path"]),
    (["mesh.h_heel"], ["KEY.PATH=VALUE"]),
    (['mesh.h_heel="fine"'], ["mesh.h_heel", "'fine'", "wrong type", "float"]),
    (["mesh.order=1.5"], ["mesh.order", "1.5", "integer"]),
    (["mesh.lumped_mass=1"], ["mesh.lumped_mass", "boolean"]),
    (["mesh.h_heel=-0.1"], ["mesh.h_heel", "-0.1", "out of range", "(0.0, 10.0]"]),
    (["materials.dam.nu=0.5"], ["materials.dam.nu", "0.5", "[0.0, 0.5)"]),
    (["time.newmark_gamma=0.4"], ["time.newmark_gamma", "0.4", "[0.5, 1.0]"]),
    (["geometry.foundation=soft"], ["geometry.foundation", "'soft'", "rock", "rigid"]),
    (["interface.contact=glue"], ["interface.contact", "linear", "rough"]),
    (["damping.modes=[1]"], ["damping.modes", "two distinct"]),
    (["ground_motion.components=['z']"], ["ground_motion.components[0]", "'z'"]),
    (["mesh.h_heel=5.0"], ["mesh.h_heel", "h_interface"]),         # cross-check
])
def test_errors(bad, words):
    with pytest.raises(ValueError) as e:
        load_scene("koyna", bad)
    msg = str(e.value)
    for w in words:
        assert w in msg, msg


def test_unknown_key_in_file(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text('[materials.dam]\nE = 1e9\nyoung = 2\n')
    with pytest.raises(ValueError, match=r"materials\.dam\.young = 2: unknown key"):
        load_scene(p)
    with pytest.raises(ValueError, match="shipped scenes"):
        load_scene("no_such_scene")
    with pytest.raises(ValueError, match="wrong type"):
        from_dict({"mesh": 3})


def test_shipped_dir_has_only_valid_scenes():
    from ngs_driver.scene import SCENE_KINDS
    kinds = []
    for p in SCENE_DIR.glob("*.toml"):
        sc = load_scene(p)
        assert isinstance(sc, SCENE_KINDS[sc.kind])
        kinds.append(sc.kind)
    assert {"koyna", "material_point", "dcb"} <= set(kinds)
    assert isinstance(load_scene("koyna"), Scene)
