"""Issue 9, item 5: every result and checkpoint file is written through the atomic helpers of
``neurocog_gym.io`` (temp file + rename), so a kill never leaves a half-written file.

A static audit of the package and the scripts (files under version control), plus the helpers'
own behaviour when the writer fails half-way.
"""

import ast
import subprocess
from pathlib import Path

import pytest

from neurocog_gym import io

ROOT = Path(__file__).resolve().parents[2]
# Writes to these names are writes into memory (``io.BytesIO``) or into a temp path that
# ``io.atomic_path`` renames: allowed.
MEMORY_OR_TEMP = {"buf", "tmp"}
SAVERS = {  # call -> index of the file argument
    "np.save": 0, "np.savez": 0, "np.savez_compressed": 0, "numpy.save": 0,
    "torch.save": 1, "pickle.dump": 1, "json.dump": 1,
    "imageio.imwrite": 0, "imageio.mimsave": 0, "imageio.imsave": 0, "imageio.get_writer": 0,
    "iio.imwrite": 0,
}  # fmt: skip


def _dotted(node) -> str:
    if isinstance(node, ast.Attribute):
        return f"{_dotted(node.value)}.{node.attr}"
    if isinstance(node, ast.Name):
        return node.id
    return "?"


def _is_memory(arg) -> bool:
    return isinstance(arg, ast.Name) and arg.id in MEMORY_OR_TEMP


def violations(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    out = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        name = _dotted(node.func)
        where = f"{path.relative_to(ROOT)}:{node.lineno}"
        if name == "open" or name.endswith(".open") and not name.startswith("np."):
            mode = node.args[1] if len(node.args) > 1 else None
            for kw in node.keywords:
                if kw.arg == "mode":
                    mode = kw.value
            if isinstance(mode, ast.Constant) and set(str(mode.value)) & set("wxa+"):
                out.append(f"{where}: open(..., {mode.value!r})")
        elif name.endswith((".write_text", ".write_bytes")):
            out.append(f"{where}: {name.rsplit('.', 1)[1]}")
        elif name.endswith(".savefig"):
            if not (node.args and _is_memory(node.args[0])):
                out.append(f"{where}: savefig to a path")
        elif name.endswith((".to_csv", ".to_parquet")) or name.startswith("shutil.copy"):
            out.append(f"{where}: {name}")
        elif name in SAVERS:
            i = SAVERS[name]
            if not (len(node.args) > i and _is_memory(node.args[i])):
                out.append(f"{where}: {name} to a path")
    return out


def _tracked_sources() -> list[Path]:
    try:
        cmd = ["git", "ls-files", "neurocog_gym", "scripts"]
        res = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=True)
        names = res.stdout.split()
    except (OSError, subprocess.CalledProcessError):
        names = [str(p.relative_to(ROOT)) for d in ("neurocog_gym", "scripts")
                 for p in (ROOT / d).rglob("*.py")]  # fmt: skip
    return [ROOT / n for n in names if n.endswith(".py") and n != "neurocog_gym/io.py"]


def test_every_file_write_goes_through_the_atomic_helpers():
    files = _tracked_sources()
    assert len(files) > 20
    found = [v for f in files if f.exists() for v in violations(f)]
    assert not found, "write these through neurocog_gym.io (atomic):\n" + "\n".join(found)


def test_the_audit_catches_each_kind_of_plain_write(tmp_path):
    src = tmp_path / "bad.py"
    src.write_text(
        "import json, shutil, numpy as np, torch\n"
        "open('a', 'w')\n"
        "open('a', mode='ab')\n"
        "p.write_text('x')\n"
        "fig.savefig('a.png')\n"
        "np.savez('a.npz', x=1)\n"
        "torch.save(obj, 'a.pt')\n"
        "json.dump(obj, f)\n"
        "shutil.copyfile('a', 'b')\n"
        "imageio.mimsave('a.mp4', frames)\n"
        # allowed: reading, and writing into memory or into atomic_path's temp file
        "open('a')\nopen('a', 'rb')\nnp.savez(buf, x=1)\ntorch.save(obj, buf)\n"
        "fig.savefig(buf, format='png')\nimageio.mimsave(tmp, frames)\n"
    )
    global ROOT
    old, ROOT = ROOT, tmp_path
    try:
        found = violations(src)
    finally:
        ROOT = old
    assert [int(v.split(":")[1]) for v in found] == list(range(2, 11)), found


class _Boom(Exception):
    pass


def test_a_failed_write_leaves_the_old_file_and_no_temp(tmp_path):
    target = tmp_path / "result.json"
    io.atomic_write_json(target, {"v": 1})

    class Exploding:
        def savefig(self, buf, **kw):
            buf.write(b"half a figure")
            raise _Boom

    with pytest.raises(_Boom):
        io.atomic_savefig(Exploding(), tmp_path / "fig.png")
    with pytest.raises(_Boom), io.atomic_path(target) as tmp:
        tmp.write_text('{"v": 2, "trunc')
        raise _Boom
    assert target.read_text() == '{\n "v": 1\n}\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["result.json"]
    with io.atomic_path(target) as tmp:
        tmp.write_text('{"v": 3}')
    assert target.read_text() == '{"v": 3}'


def test_written_files_get_ordinary_permissions(tmp_path):
    """A new file gets what open() would give it (0o666 less the umask), not mkstemp's 0o600;
    a replaced file keeps its own mode."""
    import os

    mask = os.umask(0o022)
    try:
        io.atomic_write_text(tmp_path / "new.json", "{}")
        assert (tmp_path / "new.json").stat().st_mode & 0o777 == 0o644
        with io.atomic_path(tmp_path / "video.mp4") as tmp:
            tmp.write_bytes(b"x")
        assert (tmp_path / "video.mp4").stat().st_mode & 0o777 == 0o644
        (tmp_path / "private.json").write_text("{}")
        (tmp_path / "private.json").chmod(0o600)
        io.atomic_write_text(tmp_path / "private.json", "[]")
        assert (tmp_path / "private.json").stat().st_mode & 0o777 == 0o600
    finally:
        os.umask(mask)
