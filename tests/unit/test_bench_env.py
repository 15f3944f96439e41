"""The benchmark's environment for a server of another checkout (tools/bench.py _tree_env)."""

import os

from fogbank.tools.bench import _tree_env


def test_the_earlier_trees_server_has_its_folder_first_and_keeps_the_paths_already_set(monkeypatch, tmp_path):
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(["/opt/site", "", "/opt/more"]))
    env = _tree_env(str(tmp_path / "old" / "server"))
    assert env == {"PYTHONPATH": os.pathsep.join([str(tmp_path / "old" / "server"), "/opt/site", "/opt/more"])}


def test_with_no_pythonpath_set_only_the_tree(monkeypatch, tmp_path):
    monkeypatch.delenv("PYTHONPATH", raising=False)
    assert _tree_env(str(tmp_path)) == {"PYTHONPATH": str(tmp_path)}
