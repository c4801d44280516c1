"""Hostile outputs (issue 21): no user file, folder or device is replaced, an output that is an
input is refused however it is spelt, a full disk names the file, a killed run's temporaries
are removed by the next run and nothing else is. Each refusal: status 2, one line, nothing
written.

The matrix (docs/outputs.md): a folder with foreign files, a folder of ours with a file added
later, a sibling named like the old code's ``.NAME.old``, a FIFO, a character device (a copy
of /dev/null made with mknod, as root) and /dev/null itself, a read-only file, a read-only
folder or file system, input = output through a symbolic link, a hard link or ``../``, a
full disk (a 64 KiB tmpfs as root; a writer raising ENOSPC everywhere), kill -9 mid-write.
"""

from __future__ import annotations

import errno
import io
import json
import os
import shutil
import socket
import stat
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from trebuchet.cli import main
from trebuchet.core import output
from trebuchet.core.errors import TrebuchetInputError
from trebuchet.core.output import OUTPUT_MARKER, atomic_dir, check_target, write_csv

from .conftest import HORSDAL, ROOT

LOG = ROOT / "data_samples" / "horsdal_240fps.csv"
ROOT_USER = hasattr(os, "geteuid") and os.geteuid() == 0


def _refused(capsys, argv: list, *words: str) -> str:
    """Run the command line: status 2 and one line on stderr holding ``words``."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as stop:
        code = stop.code
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert len(err) == 1 and "Traceback" not in err[0], err
    for word in words:
        assert word in err[0], (word, err[0])
    return err[0]


def _tree(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` with its bytes (hidden ones too)."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def _ours(folder: Path, files: dict[str, str]) -> Path:
    """A folder as this package leaves it: ``files`` and the marker listing them."""
    folder.mkdir()
    for name, text in files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(text)
    (folder / OUTPUT_MARKER).write_text(json.dumps({"written_by": "trebuchet",
                                                    "files": sorted(files)}))
    return folder


def _write_dir(target: Path, files: dict[str, str], **kwargs) -> None:
    with atomic_dir(target, **kwargs) as tmp:
        for name, text in files.items():
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / name).write_text(text)


# --------------------------------------------------------------------------- folders


@pytest.mark.parametrize("command", [
    ["report", HORSDAL, "--quiet"],
    ["compare", LOG, "--scene", HORSDAL, "--quiet"],
])
def test_a_folder_with_an_index_and_a_users_file_is_refused_and_kept(tmp_path, capsys,
                                                                     command):
    folder = tmp_path / "site"
    folder.mkdir()
    (folder / "index.html").write_text("<p>my page</p>")
    (folder / "thesis.tex").write_text("\\documentclass{article}")
    before = _tree(folder)
    _refused(capsys, [*command, "-o", folder], str(folder), "other files")
    assert _tree(folder) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["site"]


def test_a_folder_of_ours_is_replaced_and_its_marker_lists_every_file(tmp_path):
    out = tmp_path / "rep"
    _write_dir(out, {"index.html": "one", "a.png": "x", "sub/b.csv": "1"})
    listed = json.loads((out / OUTPUT_MARKER).read_text())["files"]
    assert listed == ["a.png", "index.html", "sub/b.csv"]
    _write_dir(out, {"index.html": "two"})
    assert _tree(out).keys() == {OUTPUT_MARKER, "index.html"}
    assert (out / "index.html").read_text() == "two"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]  # no temporary, no old copy


@pytest.mark.parametrize("added", ["thesis.tex", "sub/notes.txt", "extra/"])
def test_a_users_file_put_into_a_folder_of_ours_is_never_deleted(tmp_path, capsys, added):
    out = _ours(tmp_path / "rep", {"index.html": "old", "sub/b.csv": "1"})
    if added.endswith("/"):
        (out / added).mkdir()
    else:
        (out / added).write_text("mine")
    before = _tree(out)
    with pytest.raises(TrebuchetInputError, match=added.rstrip("/")):
        _write_dir(out, {"index.html": "new"})
    assert _tree(out) == before
    _refused(capsys, ["report", HORSDAL, "-o", out, "--quiet"], added.rstrip("/"))
    assert _tree(out) == before


def test_a_link_or_fifo_under_one_of_our_names_is_not_ours(tmp_path):
    elsewhere = tmp_path / "precious.txt"
    elsewhere.write_text("keep")
    out = _ours(tmp_path / "rep", {"index.html": "old"})
    (out / "index.html").unlink()
    (out / "index.html").symlink_to(elsewhere)
    with pytest.raises(TrebuchetInputError, match="index.html"):
        _write_dir(out, {"index.html": "new"})
    assert (out / "index.html").is_symlink() and elsewhere.read_text() == "keep"


def test_a_user_file_added_while_the_report_is_drawn_stops_the_swap(tmp_path):
    out = _ours(tmp_path / "rep", {"index.html": "old"})
    with pytest.raises(TrebuchetInputError, match="thesis.tex"), atomic_dir(out) as tmp:
        (tmp / "index.html").write_text("new")
        (out / "thesis.tex").write_text("written meanwhile")
    assert _tree(out).keys() == {OUTPUT_MARKER, "index.html", "thesis.tex"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_an_empty_marker_of_earlier_versions_still_means_a_flat_report(tmp_path):
    out = tmp_path / "rep"
    out.mkdir()
    for name in ("index.html", "tension.png", "peaks.csv"):
        (out / name).write_text("old")
    (out / OUTPUT_MARKER).touch()
    _write_dir(out, {"index.html": "new"})
    assert _tree(out).keys() == {OUTPUT_MARKER, "index.html"}
    (out / OUTPUT_MARKER).write_text("")
    (out / "thesis.tex").write_text("mine")
    with pytest.raises(TrebuchetInputError, match="thesis.tex"):
        _write_dir(out, {"index.html": "newer"})


def test_a_sibling_named_like_an_old_copy_is_left_alone(tmp_path):
    out = tmp_path / "rep"
    sibling = tmp_path / ".rep.old"
    sibling.mkdir()
    (sibling / "notes.txt").write_text("mine")
    for text in ("one", "two"):
        _write_dir(out, {"index.html": text})
    assert (sibling / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == [".rep.old", "rep"]


# --------------------------------------------------------------------------- not regular files


def _special(tmp_path: Path, kind: str) -> Path:
    path = tmp_path / kind
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "socket":
        sock = socket.socket(socket.AF_UNIX)
        sock.bind(str(path))
        sock.close()
    else:  # a character device with /dev/null's numbers
        if not ROOT_USER:
            pytest.skip("mknod of a device needs root")
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    return path


@pytest.mark.parametrize("kind, said", [("fifo", "FIFO"), ("socket", "socket"),
                                        ("device", "character device")])
def test_a_fifo_socket_or_device_is_never_replaced(tmp_path, capsys, kind, said):
    path = _special(tmp_path, kind)
    mode = os.lstat(path).st_mode
    _refused(capsys, ["simulate", HORSDAL, "-o", path, "--dt", "0.01"], str(path), said)
    _refused(capsys, ["report", HORSDAL, "-o", path, "--quiet"], str(path), said)
    assert os.lstat(path).st_mode == mode
    assert sorted(p.name for p in tmp_path.iterdir()) == [kind]


def test_the_systems_dev_null_is_refused_before_anything_is_made():
    """As root, replacing /dev/null would break the machine; the refusal comes before any
    temporary is made beside it. (Only the check is called here, never a writer: were the
    check broken, a writer would replace the machine's /dev/null.)"""
    before = sorted(os.listdir("/dev"))
    with pytest.raises(TrebuchetInputError, match="character device"):
        check_target("/dev/null")
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    assert sorted(os.listdir("/dev")) == before


def test_a_read_only_file_is_not_replaced(tmp_path, capsys):
    path = tmp_path / "kept.csv"
    path.write_text("keep\n")
    path.chmod(0o444)
    _refused(capsys, ["simulate", HORSDAL, "-o", path, "--dt", "0.01"], str(path), "read-only")
    assert path.read_text() == "keep\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.csv"]


def _mount_tmpfs(where: Path, options: str) -> bool:
    if not ROOT_USER or not shutil.which("mount"):
        return False
    where.mkdir()
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)],
                          capture_output=True)
    return proc.returncode == 0


def _umount(where: Path) -> None:
    subprocess.run(["umount", str(where)], capture_output=True)


def test_a_read_only_folder_is_refused_in_one_line(tmp_path, capsys):
    folder = tmp_path / "ro"
    mounted = _mount_tmpfs(folder, "size=1m,ro")
    if not mounted:
        if ROOT_USER:
            pytest.skip("as root only a read-only mount keeps root out; mount failed")
        folder.mkdir(exist_ok=True)
        folder.chmod(0o555)
    try:
        _refused(capsys, ["simulate", HORSDAL, "-o", folder / "run.csv", "--dt", "0.01"],
                 str(folder / "run.csv"))
        _refused(capsys, ["report", HORSDAL, "-o", folder / "rep", "--quiet"],
                 str(folder / "rep"))
        assert os.listdir(folder) == []
    finally:
        _umount(folder) if mounted else folder.chmod(0o755)


# --------------------------------------------------------------------------- input = output


def _copy(src: Path, dst: Path) -> Path:
    shutil.copyfile(src, dst)
    return dst


@pytest.mark.parametrize("spelling", ["same", "symlink", "hardlink", "dotdot"])
def test_forces_never_writes_over_its_log(tmp_path, capsys, monkeypatch, spelling):
    monkeypatch.chdir(tmp_path)
    log = _copy(LOG, tmp_path / "log.csv")
    (tmp_path / "sub").mkdir()
    output = {"same": "log.csv", "symlink": "link.csv", "hardlink": "hard.csv",
              "dotdot": "sub/../log.csv"}[spelling]
    if spelling == "symlink":
        Path("link.csv").symlink_to("log.csv")
    if spelling == "hardlink":
        os.link("log.csv", "hard.csv")
    before = _tree(tmp_path)
    _refused(capsys, ["forces", "log.csv", "--scene", HORSDAL, "-o", output], "input")
    assert _tree(tmp_path) == before and log.read_bytes() == LOG.read_bytes()
    assert (tmp_path / "link.csv").is_symlink() == (spelling == "symlink")


@pytest.mark.parametrize("command", [
    ["simulate", "{scene}", "-o", "{scene}", "--dt", "0.01"],
    ["paper", "--scene", "{scene}", "-o", "{link}"],
    ["sweep", "{scene}", "--grid", "engine.M=19100", "-o", "{scene}", "--quiet"],
    ["forces", LOG, "--scene", "{scene}", "-o", "{link}"],
    ["compare", LOG, "--scene", "{scene}", "-o", "{folder}", "--quiet"],
    ["report", "{scene}", "-o", "{folder}", "--quiet"],
])
def test_no_command_writes_over_its_scene(tmp_path, capsys, command):
    folder = _ours(tmp_path / "rep", {"index.html": "old"})
    scene = _copy(HORSDAL, folder / "scene.toml")
    (tmp_path / "link.toml").symlink_to(scene)
    argv = [str(a).format(scene=scene, link=tmp_path / "link.toml", folder=folder)
            for a in command]
    before = _tree(tmp_path)
    _refused(capsys, argv, "input")
    assert _tree(tmp_path) == before


def test_compare_refuses_a_report_folder_that_holds_its_log(tmp_path, capsys):
    folder = _ours(tmp_path / "rep", {"index.html": "old", "log.csv": "listed as ours"})
    _copy(LOG, folder / "log.csv")
    before = _tree(folder)
    _refused(capsys, ["compare", folder / "log.csv", "--scene", HORSDAL, "-o", folder,
                      "--quiet"], "log.csv", "input")
    assert _tree(folder) == before


def test_fmu_commands_refuse_their_own_inputs(tmp_path, capsys, monkeypatch):
    from trebuchet.fmu import csources

    glue = tmp_path / "c"
    shutil.copytree(csources.GLUE_DIR, glue)
    monkeypatch.setattr(csources, "GLUE_DIR", glue)
    before = _tree(glue)
    _refused(capsys, ["fmu", "build", "-o", glue / "treb_shot.c"], "treb_shot.c", "input")
    assert _tree(glue) == before
    cross = _ours(tmp_path / "cross", {"Trebuchet.fmu": "an FMU"})
    _refused(capsys, ["fmu", "crosscheck", cross / "Trebuchet.fmu", "-o", cross], "input")
    assert (cross / "Trebuchet.fmu").read_text() == "an FMU"


def test_a_symbolic_link_output_writes_the_file_it_points_to(tmp_path, capsys):
    data = tmp_path / "data.csv"
    data.write_text("old\n")
    link = tmp_path / "latest.csv"
    link.symlink_to(data)
    assert main(["paper", "-o", str(link)]) == 0
    capsys.readouterr()
    assert link.is_symlink() and data.read_text().startswith("section,")


# --------------------------------------------------------------------------- full disk


def test_a_full_disk_names_the_file_and_leaves_nothing(tmp_path, capsys, monkeypatch):
    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    class FullFile(io.StringIO):  # the CSV writer's file: a disk with no room
        write = full

    from trebuchet import csv_table

    monkeypatch.setattr(pd.DataFrame, "to_csv", full)
    monkeypatch.setattr(csv_table, "open", lambda *a, **k: FullFile(), raising=False)
    out = tmp_path / "run.csv"
    line = _refused(capsys, ["simulate", HORSDAL, "-o", out, "--dt", "0.01"], str(out),
                    "No space left on device")
    assert line == f"trebuchet: error: {out}: cannot write: No space left on device"
    from matplotlib.figure import Figure

    monkeypatch.setattr(Figure, "savefig", full)
    _refused(capsys, ["report", HORSDAL, "-o", tmp_path / "rep", "--quiet", "--dt", "0.01"],
             str(tmp_path / "rep"), "No space left on device")
    assert os.listdir(tmp_path) == []


def test_a_really_full_tmpfs_names_the_file_and_leaves_nothing(tmp_path, capsys):
    full = tmp_path / "full"
    if not _mount_tmpfs(full, "size=64k"):
        pytest.skip("mounting a 64 KiB tmpfs needs root")
    try:
        out = full / "run.csv"
        _refused(capsys, ["simulate", HORSDAL, "-o", out], str(out), "No space left on device")
        assert os.listdir(full) == []
    finally:
        _umount(full)


# --------------------------------------------------------------------------- killed runs

_WRITER = """
import sys, time
from trebuchet.core.output import atomic_dir, atomic_path
target = sys.argv[2]
with (atomic_path(target) if sys.argv[1] == "file" else atomic_dir(target)) as tmp:
    if sys.argv[1] == "file":
        tmp.write_text("half a fi")
    else:
        (tmp / "index.html").write_text("half a rep")
    print(tmp, flush=True)
    time.sleep(120)
"""


@pytest.mark.parametrize("kind", ["file", "folder"])
def test_kill_9_mid_write_leaves_the_target_and_the_next_run_cleans_up(tmp_path, kind):
    target = tmp_path / ("run.csv" if kind == "file" else "rep")
    if kind == "file":
        target.write_text("old\n")
    else:
        _write_dir(target, {"index.html": "old"})
    before = _tree(target) if kind == "folder" else target.read_text()
    writer = subprocess.Popen([sys.executable, "-c", _WRITER, kind, str(target)],
                              stdout=subprocess.PIPE, text=True)
    try:
        tmp = Path(writer.stdout.readline().strip())
        assert tmp.exists() and tmp.parent == tmp_path
        assert output.remove_stale_temporaries(tmp_path) == []  # alive: its lock is held
        assert tmp.exists()
    finally:
        writer.kill()
        writer.wait()
    assert (_tree(target) if kind == "folder" else target.read_text()) == before
    assert tmp.exists()
    if kind == "file":
        write_csv(pd.DataFrame({"a": [1]}), target)
        assert target.read_text() == "a\n1\n"
    else:
        _write_dir(target, {"index.html": "new"})
        assert (target / "index.html").read_text() == "new"
    assert not tmp.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [target.name]


def test_only_our_signed_temporaries_are_ever_removed(tmp_path):
    look_alikes = [".run.csv.0123456789abcdef.trebuchet-tmp",  # wrong signature
                   ".run.csv.k2j4h5g6.tmp",  # the unsigned names of earlier versions
                   "notes.trebuchet-tmp", ".rep.old"]
    for name in look_alikes:
        (tmp_path / name).write_text("mine")
    write_csv(pd.DataFrame({"a": [1]}), tmp_path / "run.csv")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([*look_alikes, "run.csv"])
