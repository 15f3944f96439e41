import os

from fogbank.tools import bench


def test_the_earlier_tree_goes_first_and_keeps_the_paths_already_set(monkeypatch, tmp_path):
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(["/opt/site", "", "/opt/more"]))
    env = bench._tree_env(str(tmp_path / "old" / "server"))
    assert env == {"PYTHONPATH": os.pathsep.join([str(tmp_path / "old" / "server"), "/opt/site", "/opt/more"])}


def test_with_no_pythonpath_set_only_the_tree(monkeypatch, tmp_path):
    monkeypatch.delenv("PYTHONPATH", raising=False)
    assert bench._tree_env(str(tmp_path)) == {"PYTHONPATH": str(tmp_path)}
