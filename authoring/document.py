"""An animation file open in the authoring tool: load, undo/redo, save. No window here.

``Document`` holds the animation being edited (an immutable ``engine.anim.Animation``; an
edit makes a new one) and its history. Every edit is one step of the history, and a
*gesture* (a mouse drag of a body, a key or a slider) is one step however many values
it passes through: the steps of a gesture share a ``coalesce`` tag and replace each
other until the gesture ends (``end_gesture``).

Work is never lost:

- ``Document.open(path)`` reads a file; a file that does not parse opens anyway, with
  its error in ``load_error`` and an empty animation (nothing is saved over it until
  the user asks, with ``force``), so the tool can show what is wrong instead of a
  traceback. A path that does not exist opens a new animation with that name.
- ``save()`` writes the engine's animation format (``engine.anim.fileio``) and checks
  that the file reads back as the same animation. Parts of the file the edits did not
  touch (the header, whole channels) are copied from the file as it was, comments and
  all; the rest is written as the engine writes it. Undoing every edit and saving gives
  the file back byte for byte.
- Saving over a file the document did not come from (``save_as`` to an existing file)
  raises ``FileExistsError`` unless ``overwrite=True``; saving over its own file first
  copies the old file to ``NAME.yaml.bak`` (the backup of the last save).
- ``dirty`` says whether there are unsaved changes (the tool asks before closing).
"""

from __future__ import annotations

import os
import re
import shutil
from dataclasses import dataclass, field

from engine.anim import Animation, AnimationError, animation_to_text
from engine.anim.animation import ChannelDef, Key
from engine.anim.fileio import parse_animation_text
from engine.channels.modes import PositionSpec, RotationSpec
from engine.errors import MenagerieError
from engine.query import Query

#: Suffix of the backup written before a save replaces a file.
BACKUP_SUFFIX = ".bak"
#: Steps of history kept (older ones are dropped).
HISTORY_LIMIT = 500


class DocumentError(MenagerieError):
    """A document that cannot do what was asked (save a file that failed to load, ...)."""


def new_animation(name: str = "untitled", length: float = 2.0) -> Animation:
    """A new animation: one channel posing the root at rest, ready for keys."""
    ch = ChannelDef(name="root", query=Query(type="root"), position=PositionSpec(mode="rest"),
                    rotation=RotationSpec(mode="rest"),
                    position_keys=(Key(0.0, (0.0, 0.0, 0.0)),))
    return Animation(name=name, length=float(length), channels=(ch,), loop=True)


@dataclass
class _Step:
    label: str
    animation: Animation
    coalesce: object = None
    open: bool = False


_HEADER_FIELDS = ("name", "description", "length", "loop", "branches", "targets")


@dataclass
class Document:
    """An animation being edited (see the module docstring)."""

    path: str | None
    original_text: str | None
    original: Animation
    load_error: str | None = None
    _steps: list[_Step] = field(default_factory=list)
    _index: int = 0
    _saved_animation: Animation | None = None
    #: (text, animation) of every text saved from this document: untouched channels keep
    #: the text they had there (the opened file's is ``original_text``).
    _sources: list = field(default_factory=list)
    #: Called with the document after every change of ``animation`` (edit, undo, redo).
    on_change: object = None

    # -- opening -------------------------------------------------------------------------

    @classmethod
    def open(cls, path: str | os.PathLike) -> Document:
        """Open ``path`` (see the module docstring: a missing file is a new animation, a
        broken one opens with ``load_error`` set)."""
        p = os.fspath(path)
        if not os.path.exists(p):
            name = os.path.splitext(os.path.basename(p))[0] or "untitled"
            return cls._make(p, None, new_animation(_safe_name(name)))
        try:
            with open(p, encoding="utf-8") as f:
                text = f.read()
        except (OSError, UnicodeDecodeError) as exc:
            doc = cls._make(p, None, new_animation(_safe_name(os.path.basename(p))))
            doc.load_error = f"{p}: cannot read the file ({exc})"
            return doc
        try:
            anim = parse_animation_text(text, p)
        except MenagerieError as exc:
            doc = cls._make(p, text, new_animation(_safe_name(os.path.splitext(os.path.basename(p))[0])))
            doc.load_error = str(exc)
            return doc
        return cls._make(p, text, anim)

    @classmethod
    def from_animation(cls, animation: Animation, path: str | None = None) -> Document:
        """A document for an animation built in code (never saved yet)."""
        return cls._make(path, None, animation)

    @classmethod
    def _make(cls, path, text, anim) -> Document:
        doc = cls(path=path, original_text=text, original=anim)
        doc._steps = [_Step("open", anim)]
        doc._index = 0
        doc._saved_animation = anim if text is not None else None
        return doc

    # -- the animation and its history ------------------------------------------------------

    @property
    def animation(self) -> Animation:
        return self._steps[self._index].animation

    @property
    def dirty(self) -> bool:
        """Unsaved changes (a new file is dirty until saved)."""
        return self._saved_animation is None or self.animation != self._saved_animation

    def apply(self, animation: Animation, label: str, *, coalesce=None) -> Animation:
        """Make ``animation`` the current state, as one step named ``label``. A step with
        the same ``coalesce`` tag as the open step on top replaces it (a gesture)."""
        if not isinstance(animation, Animation):
            raise TypeError(f"apply needs an Animation, got {type(animation).__name__}")
        top = self._steps[self._index]
        if coalesce is not None and top.open and top.coalesce == coalesce:
            top.animation = animation
            top.label = label
        else:
            if top.open:
                top.open = False
            if animation == self.animation and coalesce is None:
                return animation            # no change, no step
            del self._steps[self._index + 1:]
            self._steps.append(_Step(label, animation, coalesce, coalesce is not None))
            if len(self._steps) > HISTORY_LIMIT:
                del self._steps[0]
            self._index = len(self._steps) - 1
        self._changed()
        return animation

    def end_gesture(self) -> None:
        """Close the open gesture: the next edit is a step of its own. A gesture that
        changed nothing leaves no step."""
        top = self._steps[self._index]
        if top.open:
            top.open = False
            if self._index > 0 and top.animation == self._steps[self._index - 1].animation:
                del self._steps[self._index:]
                self._index -= 1

    def undo(self) -> bool:
        """Go one step back; False when there is nothing to undo."""
        self.end_gesture()
        if self._index == 0:
            return False
        self._index -= 1
        self._changed()
        return True

    def redo(self) -> bool:
        """Go one step forward again; False when there is nothing to redo."""
        self.end_gesture()
        if self._index >= len(self._steps) - 1:
            return False
        self._index += 1
        self._changed()
        return True

    @property
    def can_undo(self) -> bool:
        return self._index > 0

    @property
    def can_redo(self) -> bool:
        return self._index < len(self._steps) - 1

    def history(self) -> list[str]:
        """Labels of the steps, oldest first ("open" is the file as opened)."""
        return [s.label for s in self._steps[: self._index + 1]]

    def _changed(self) -> None:
        if self.on_change is not None:
            self.on_change(self)

    # -- saving ------------------------------------------------------------------------------

    def text(self) -> str:
        """The file text ``save`` would write (see the module docstring)."""
        anim = self.animation
        sources = list(reversed(self._sources))
        if self.original_text is not None and self.load_error is None:
            sources.append((self.original_text, self.original))
        for text, known in sources:
            if known == anim:
                return text
        spliced = splice_text(sources, anim) if sources else None
        return spliced if spliced is not None else animation_to_text(anim)

    def save(self, *, force: bool = False) -> str:
        """Write the animation to its own file (keeping a backup of the old one).
        A document whose file failed to load is not saved over it unless ``force``."""
        if self.path is None:
            raise DocumentError("this animation has no file yet: use save_as(path)")
        if self.load_error is not None and not force and os.path.exists(self.path):
            raise DocumentError(f"{self.path} did not load ({self.load_error}); saving would replace it "
                                "with a new animation: save elsewhere, or save with force")
        return self._write(self.path, backup=True)

    def save_as(self, path: str | os.PathLike, *, overwrite: bool = False) -> str:
        """Write to ``path`` and make it the document's file. An existing file that is not
        the document's own is replaced only with ``overwrite``."""
        p = os.fspath(path)
        own = self.path is not None and os.path.exists(p) and os.path.samefile(p, self.path)
        if os.path.exists(p) and not own and not overwrite:
            raise FileExistsError(f"{p} exists; choose another name or overwrite it explicitly")
        return self._write(p, backup=True)

    def _write(self, path: str, *, backup: bool) -> str:
        text = self.text()
        try:
            again = parse_animation_text(text, path)
        except AnimationError as exc:  # a bug of ours, never a silent bad file
            raise DocumentError(f"refusing to save {path}: the text does not read back ({exc})") from None
        if again != self.animation:
            raise DocumentError(f"refusing to save {path}: the text reads back as a different animation")
        d = os.path.dirname(path)
        if d:
            os.makedirs(d, exist_ok=True)
        if backup and os.path.exists(path):
            shutil.copy2(path, path + BACKUP_SUFFIX)
        tmp = path + ".saving"
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
        if self.load_error is not None:
            self.original_text, self.original = text, self.animation
        self._sources.append((text, self.animation))
        self.path = path
        self.load_error = None
        self._saved_animation = self.animation
        return path


def _safe_name(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name) or "untitled"


# -- keeping the untouched parts of a file ------------------------------------------------------


def _channel_blocks(text: str, original: Animation) -> tuple[list[str], list[list[str]]] | None:
    """The file's lines before its channels (the header, with the ``channels:`` line)
    and each channel's lines (with the comments just above it), or None when the file's
    layout is not one this can split."""
    lines = text.splitlines(keepends=True)
    chan_line = None
    for i, line in enumerate(lines):
        if re.match(r"^channels\s*:", line):
            chan_line = i
            break
    if chan_line is None:
        return None
    starts = [ch.line - 1 for ch in original.channels]
    if not starts or any(s <= chan_line for s in starts) or starts != sorted(starts):
        return None
    # Comment lines right above a channel belong to it.
    bounds = []
    for s in starts:
        b = s
        while b - 1 > chan_line and lines[b - 1].lstrip().startswith("#"):
            b -= 1
        bounds.append(b)
    # Anything after `channels:` must be channel items (no other top-level key after it).
    for line in lines[chan_line + 1:]:
        if line.strip() and not line[0].isspace() and not line.startswith(("#", "-")):
            return None
    header = lines[: bounds[0]]
    blocks = [lines[bounds[k]: bounds[k + 1] if k + 1 < len(bounds) else len(lines)]
              for k in range(len(bounds))]
    if blocks and not blocks[-1][-1].endswith("\n"):
        blocks[-1][-1] += "\n"
    return header, blocks


def splice_text(sources, animation: Animation) -> str | None:
    """The text of ``animation`` made from ``sources``, a list of (file text, the animation
    it reads as), most preferred first: the header of the first source whose header fields
    are the same, and each channel that is the same as one in a source, are copied as
    they were there (comments and all); the rest is written by the engine's writer. None
    when no source can be split into a header and channel blocks."""
    split = []
    for text, original in sources:
        parts = _channel_blocks(text, original)
        if parts is not None:
            split.append((parts, original))
    if not split:
        return None
    fresh = animation_to_text(animation).splitlines(keepends=True)
    k = fresh.index("channels:\n")
    fresh_header = fresh[: k + 1]
    fresh_blocks = _split_fresh_channels(fresh[k + 1:])
    out = None
    for (header, _blocks), original in split:
        if all(getattr(animation, f) == getattr(original, f) for f in _HEADER_FIELDS):
            out = list(header)
            break
    if out is None:
        out = list(fresh_header)
    for ci, ch in enumerate(animation.channels):
        block = None
        for (_header, blocks), original in split:
            old = _find_same(original, ch)
            if old is not None:
                block = blocks[old]
                break
        out += block if block is not None else fresh_blocks[ci]
    result = "".join(out)
    try:
        if parse_animation_text(result) != animation:
            return None
    except AnimationError:
        return None
    return result


def _find_same(original: Animation, ch: ChannelDef) -> int | None:
    for i, old in enumerate(original.channels):
        if old == ch:
            return i
    return None


def _split_fresh_channels(lines: list[str]) -> list[list[str]]:
    blocks: list[list[str]] = []
    for line in lines:
        if line.startswith("  - "):
            blocks.append([])
        blocks[-1].append(line)
    return blocks
