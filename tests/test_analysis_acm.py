"""The allowed-collision matrix (manipkit.analysis.acm): MoveIt's rules on a hand-made robot and on the Panda."""

import re

import pytest

import manipkit
from manipkit.analysis.acm import allowed_collision_matrix, srdf_text
from manipkit.errors import CollisionError, OptionError
from manipkit.kinematics.collisions import collisions, read_srdf
from manipkit.kinematics.robot import Robot

# A wall of two boxes covering |x| >= 0.03 (y, z within 0.05), fixed to the base; a ball b (r = 0.01) sliding
# along x in [-1, 1] through the gap, with a ball d fixed 0.5 m beside it; a ball c lifted 1 to 2 m; a ball e
# fixed inside the wall at x = 0.5.
#   b - wall: contact when |x| > 0.02, in 98 % of uniform samples, not at the default x = 0  -> Always
#   b - d: joined by a fixed joint                                                          -> Adjacent
#   e - wall: rigid and in contact                                                          -> Default
#   b - e: contact when |x - 0.5| < 0.06, about 6 % of samples                              -> enabled
#   c with anything, d with the wall or e: never within reach                               -> Never
RULES = """<?xml version="1.0"?>
<robot name="rules">
  <link name="base_link"/>
  <link name="wall">
    <collision><origin xyz="1.015 0 0"/><geometry><box size="1.97 0.1 0.1"/></geometry></collision>
    <collision><origin xyz="-1.015 0 0"/><geometry><box size="1.97 0.1 0.1"/></geometry></collision>
  </link>
  <link name="b"><collision><geometry><sphere radius="0.01"/></geometry></collision></link>
  <link name="d"><collision><geometry><sphere radius="0.01"/></geometry></collision></link>
  <link name="c"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <link name="e"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <joint name="wall_joint" type="fixed"><parent link="base_link"/><child link="wall"/></joint>
  <joint name="slide" type="prismatic">
    <parent link="base_link"/><child link="b"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="beside" type="fixed"><parent link="b"/><child link="d"/><origin xyz="0 0.5 0"/></joint>
  <joint name="lift" type="prismatic">
    <parent link="base_link"/><child link="c"/><axis xyz="0 0 1"/><limit lower="1" upper="2" effort="1" velocity="1"/>
  </joint>
  <joint name="inside" type="fixed"><parent link="base_link"/><child link="e"/><origin xyz="0.5 0 0"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def rules():
    return Robot.from_urdf(RULES)


@pytest.fixture(scope="module")
def panda():
    return manipkit.load("panda")


def test_each_rule_disables_the_pair_worked_out_by_hand(rules):
    matrix = allowed_collision_matrix(rules, samples=400, seed=1)
    assert dict(matrix.disabled) == {
        ("b", "d"): "Adjacent",
        ("e", "wall"): "Default",
        ("b", "wall"): "Always",
        ("b", "c"): "Never", ("c", "d"): "Never", ("c", "e"): "Never", ("c", "wall"): "Never",
        ("d", "e"): "Never", ("d", "wall"): "Never",
    }
    assert matrix.enabled == (("b", "e"),)
    assert 0 < matrix.contacts[("b", "e")] < 0.2 * 400  # about 6 % of the samples
    assert matrix.contacts[("b", "wall")] >= 0.95 * 400
    assert matrix.default_contacts == ()
    assert matrix.counts() == {"Adjacent": 1, "Default": 1, "Always": 1, "Never": 6}


def test_the_srdf_reads_back_and_leaves_the_default_pose_free(tmp_path, rules):
    matrix = allowed_collision_matrix(rules, samples=200)
    path = tmp_path / "rules.srdf"
    path.write_text(srdf_text(matrix))
    assert read_srdf(path, rules) == dict(matrix.disabled)
    assert not collisions(rules, srdf=path).in_collision
    # b inside the wall at x = -0.5: checked without the matrix, disabled (Always) with it
    assert [(p.link1, p.link2) for p in collisions(rules, [-0.5, 1.0]).pairs] == [("b", "wall")]
    assert not collisions(rules, [-0.5, 1.0], srdf=path).in_collision


def test_same_seed_same_matrix(rules):
    assert allowed_collision_matrix(rules, samples=50, seed=7) == allowed_collision_matrix(rules, samples=50, seed=7)


def test_the_matrix_does_not_depend_on_the_thread_count(panda):
    one, two = (allowed_collision_matrix(panda, samples=3000, seed=4, workers=k) for k in (1, 2))
    assert one == two and sum(one.contacts.values()) > 0


def test_progress_is_reported_to_the_end(rules):
    seen = []
    allowed_collision_matrix(rules, samples=300, progress=lambda stage, done, total: seen.append((stage, done, total)))
    assert seen[-1] == ("sampling configurations", 300, 300)
    assert [done for _, done, _ in seen] == sorted(done for _, done, _ in seen)


@pytest.mark.parametrize("kwargs, fragment", [
    ({"samples": 0}, "samples 0: give a whole number"),
    ({"samples": 2.5}, "samples 2.5: give a whole number"),
    ({"always": 0}, "always 0: give a fraction"),
    ({"workers": 0}, "workers 0: give a whole number of threads"),
])
def test_bad_options_are_refused(rules, kwargs, fragment):
    with pytest.raises((OptionError, CollisionError), match=fragment):
        allowed_collision_matrix(rules, **kwargs)


def _pairs(text: str) -> dict:
    return {tuple(sorted(m[:2])): m[2]
            for m in re.findall(r'link1="([^"]+)" link2="([^"]+)" reason="([^"]+)"', text)}


def test_panda_matrix_disables_every_adjacent_pair_and_matches_the_shipped_srdf(panda):
    # 10,000 samples as MoveIt's Setup Assistant takes (about 2 s on hulls).
    matrix = allowed_collision_matrix(panda, samples=10_000, seed=0)
    chain = [f"panda_link{i}" for i in range(8)]
    adjacent = {tuple(sorted(p)) for p in zip(chain, chain[1:])}
    adjacent |= {("panda_hand", "panda_link7"), ("panda_hand", "panda_leftfinger"), ("panda_hand", "panda_rightfinger")}
    assert {pair for pair, reason in matrix.disabled.items() if reason == "Adjacent"} == adjacent
    assert matrix.default_contacts == ()
    shipped = _pairs((panda.source.path.parents[1] / "srdf" / "panda.srdf").read_text())
    ours = _pairs(srdf_text(matrix))
    # The differences from example-robot-data's SRDF, each with its reason: none on hulls with 10,000 samples
    # (the same 35 pairs with the same reasons: 10 Adjacent, 3 Default, 22 Never).
    differences = {pair: (shipped.get(pair), ours.get(pair)) for pair in set(shipped) | set(ours)
                   if shipped.get(pair) != ours.get(pair)}
    assert differences == {}
    assert matrix.counts() == {"Adjacent": 10, "Default": 3, "Always": 0, "Never": 22}


def test_the_panda_srdf_is_moveit_shaped(panda):
    text = srdf_text(allowed_collision_matrix(panda, samples=20))
    lines = text.splitlines()
    assert lines[0] == '<?xml version="1.0" encoding="utf-8"?>'
    assert lines[2] == '<robot name="panda">' and lines[-1] == "</robot>"
    assert all(re.fullmatch(r'    <disable_collisions link1="\w+" link2="\w+" reason="(Adjacent|Default|Always|Never)"/>',
                            line) for line in lines[3:-1])
