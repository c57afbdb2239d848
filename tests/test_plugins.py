"""Plugin references: module:attr, file.py:attr, entry points of installed distributions."""

from __future__ import annotations

import os
import sys
import textwrap

import pytest

from fftnav.plugins import (
    PluginError,
    file_sha256,
    is_reference,
    load_reference,
    plugin_sources,
)


def test_module_reference_follows_dotted_attributes():
    import os.path

    assert load_reference("os.path:join") is os.path.join
    assert load_reference("os:path.join") is os.path.join
    assert is_reference("a.b:c") and is_reference("x/y.py:Z") and not is_reference("fusion")


def test_file_reference_is_loaded_once_per_process(tmp_path):
    plugin = tmp_path / "my_plugin.py"
    plugin.write_text("import itertools\nCOUNT = next(itertools.count())\nVALUE = [1, 2]\n")
    first = load_reference(f"{plugin}:VALUE")
    assert first == [1, 2] and load_reference(f"{plugin}:VALUE") is first


@pytest.mark.parametrize(("text", "match"), [
    ("no_such_module_xyz:thing", r"cannot load 'no_such_module_xyz:thing': "
                                 r"ModuleNotFoundError: No module named 'no_such_module_xyz'"),
    ("math:nothing", r"module 'math' has no attribute 'nothing'"),
    ("/no/such/dir/p.py:X", r"no such file '/no/such/dir/p\.py'"),
    ("just-a-name", r"'just-a-name' is not a plugin reference"),
    ("", r"non-empty string"),
])
def test_bad_references_are_refused_in_one_line(text, match):
    with pytest.raises(PluginError, match=match) as info:
        load_reference(text, group="fftnav.test-none")
    assert "\n" not in str(info.value)


def test_an_exception_raised_while_importing_a_file_is_one_line(tmp_path):
    plugin = tmp_path / "broken.py"
    plugin.write_text("X = 1\nraise RuntimeError('plugin is\\nbroken')\n")
    with pytest.raises(PluginError, match=r"cannot load '.*broken\.py:X': "
                                          r"RuntimeError: plugin is broken$"):
        load_reference(f"{plugin}:X")
    plugin.write_text("X = 2\n")  # a failed import is not cached
    assert load_reference(f"{plugin}:X") == 2


def test_entry_points_of_an_installed_distribution_are_found(tmp_path, monkeypatch):
    """A distribution on sys.path (dist-info with entry_points.txt) registers a name."""
    (tmp_path / "epdemo_pkg.py").write_text("ANSWER = 42\n")
    info = tmp_path / "epdemo-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: epdemo\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(textwrap.dedent("""\
        [fftnav.test-group]
        the-answer = epdemo_pkg:ANSWER
        """))
    monkeypatch.syspath_prepend(str(tmp_path))
    assert load_reference("the-answer", group="fftnav.test-group") == 42
    with pytest.raises(PluginError, match="nor an entry point of group 'fftnav.test-group'"):
        load_reference("the-question", group="fftnav.test-group")
    sys.modules.pop("epdemo_pkg", None)


def test_file_sha256_matches_hashlib_of_the_bytes(tmp_path):
    import hashlib

    f = tmp_path / "f.py"
    f.write_bytes(b"x = 1\n")
    assert file_sha256(f) == hashlib.sha256(b"x = 1\n").hexdigest()


def test_a_plugin_file_imports_the_module_beside_it_and_the_path_is_restored(tmp_path):
    folder = tmp_path / "plugin_folder"
    folder.mkdir()
    (folder / "beside_helpers_xyz.py").write_text("def side():\n    return -1\n")
    plugin = folder / "uses_helpers.py"
    plugin.write_text("from beside_helpers_xyz import side\n\n\ndef decide(context):\n"
                      "    return side()\n")
    path = list(sys.path)
    try:
        decide = load_reference(f"{plugin}:decide")
        assert decide(None) == -1 and sys.path == path
        assert plugin_sources(plugin) == (plugin.resolve(),
                                          (folder / "beside_helpers_xyz.py").resolve())
    finally:
        sys.modules.pop("beside_helpers_xyz", None)


def test_a_module_reference_is_found_in_the_current_directory(tmp_path, monkeypatch):
    (tmp_path / "cwd_module_xyz.py").write_text("VALUE = 7\n")
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", os.getcwd())])
    monkeypatch.chdir(tmp_path)
    path = list(sys.path)
    try:
        assert load_reference("cwd_module_xyz:VALUE") == 7 and sys.path == path
    finally:
        sys.modules.pop("cwd_module_xyz", None)


def _load_and_call(reference):
    return load_reference(reference)(None)


def test_a_spawned_worker_loads_a_plugin_file_importing_its_neighbour(tmp_path):
    """What a worker of ``fftnav run`` started by spawn or forkserver does: it gets the reference
    string only and loads the plugin itself."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    (tmp_path / "spawn_helpers_xyz.py").write_text("def side():\n    return -1\n")
    plugin = tmp_path / "spawned.py"
    plugin.write_text("from spawn_helpers_xyz import side\n\n\ndef decide(context):\n"
                      "    return side()\n")
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        assert pool.submit(_load_and_call, f"{plugin}:decide").result(timeout=120) == -1
