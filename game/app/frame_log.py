"""Per-frame stats kept on disk, not in memory, so that a long capture's memory stays flat.

Kept in a list, a frame's stats (about a kilobyte) would grow the process with every frame of a
long run. The log appends each frame's stats as one JSON line to an anonymous temp file and keeps
only the line offsets; the stats file is then streamed from it through
:func:`game.app.outputs.atomic_file` (temp file, then rename).
"""

from __future__ import annotations

import json
import tempfile
from array import array
from collections.abc import Iterator
from pathlib import Path

from game.app import outputs


class FrameLog:
    """A list-like, append-only sequence of per-frame dicts, stored in a temp file."""

    def __init__(self) -> None:
        self._file = tempfile.TemporaryFile()
        self._offsets = array("q")

    def append(self, entry: dict) -> None:
        self._file.seek(0, 2)
        self._offsets.append(self._file.tell())
        self._file.write(json.dumps(entry).encode() + b"\n")

    def __len__(self) -> int:
        return len(self._offsets)

    def line(self, i: int) -> bytes:
        """Frame ``i``'s entry as the JSON line spooled to disk."""
        self._file.seek(self._offsets[i])
        return self._file.readline()

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        if index < 0:
            index += len(self)
        if not 0 <= index < len(self):
            raise IndexError(index)
        return json.loads(self.line(index))

    def __iter__(self) -> Iterator[dict]:
        for i in range(len(self)):
            yield json.loads(self.line(i))

    def write_json(self, path: str | Path, document: dict, key: str = "frames") -> None:
        """Write ``document`` with this log as ``document[key]``, streamed, temp then rename."""
        head = {k: v for k, v in document.items() if k != key}
        text = json.dumps(head, indent=1)
        with outputs.atomic_file(path) as f:
            f.write(text[:-1].rstrip().encode())
            f.write(f',\n "{key}": [\n'.encode() if head else f'{{"{key}": [\n'.encode())
            for i in range(len(self)):
                f.write(self.line(i).rstrip(b"\n"))
                f.write(b",\n" if i + 1 < len(self) else b"\n")
            f.write(b"]}\n")

    def close(self) -> None:
        self._file.close()
