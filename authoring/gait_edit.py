"""Gait styles in the authoring tool: the speed rows and the foot's flight arc of
``animations/gaits/*.yaml`` (Hecker et al. 2008, section 4.2), edited and previewed walking
on the preview creatures. No window here.

``GaitEditor`` edits one style file as text: a change rewrites only the ``speeds:`` or
``flight:`` block (as flow mappings, floats written with ``repr``), every other line and
comment is kept, and the result must read back through ``engine.gait.style`` or the change
is refused with the reader's message. Undo returns earlier texts; ``save`` writes the file
with a ``.bak`` backup of the old one.

Walking preview: every preview creature with legs locomotes straight ahead at ``speed``
leg lengths per second under the edited style (``GaitController.set_style``) and is put
back where it started after ``WALK_SECONDS``, so it stays in view.
"""

from __future__ import annotations

import os
import re
import shutil

import numpy as np

from engine.errors import MenagerieError
from engine.gait.style import SPEED_FIELDS, STYLE_DIR, parse_style_text
from engine.model.fileio import read_yaml_located

WALK_SECONDS = 3.0


class GaitEditor:
    """One gait style file being edited, and the walking preview (module docstring)."""

    def __init__(self, preview, name: str = "walk") -> None:
        self.preview = preview
        self.walking = False
        self.speed = 1.0
        self.message = ""
        self._walked = 0.0
        self.open_style(name)

    # -- the file -----------------------------------------------------------------------------

    def open_style(self, name_or_path: str) -> None:
        path = name_or_path if name_or_path.endswith((".yaml", ".yml")) else \
            os.path.join(STYLE_DIR, f"{name_or_path}.yaml")
        with open(path, encoding="utf-8") as f:
            text = f.read()
        self.style = parse_style_text(text, path)
        self.path = path
        self.name = self.style.name
        self.saved_text = text
        self._texts = [text]
        self.message = ""
        if self.walking:
            self._apply_style()

    @property
    def text(self) -> str:
        return self._texts[-1]

    @property
    def dirty(self) -> bool:
        return self.text != self.saved_text

    def _fields(self):
        return read_yaml_located(self.text, self.path, error=MenagerieError).value

    def rows(self) -> list[list[float]]:
        return [list(r) for r in np.asarray(self.style.table)]

    def arc(self) -> dict | None:
        top = self._fields()
        fl = top.get("flight")
        if fl is None:
            return {"peak": 0.45, "lead": 0.15, "pitch": 0.2}
        if "arc" not in fl.value:
            return None
        arc = {k: v.value for k, v in fl.value["arc"].value.items()}
        return {"peak": float(arc.get("peak", 0.45)), "lead": float(arc.get("lead", 0.15)),
                "pitch": float(arc.get("pitch", 0.2))}

    def _replace_block(self, key: str, lines: list[str]) -> str:
        """The text with top-level ``key``'s block replaced by ``lines`` (appended when absent)."""
        text = self.text.splitlines(keepends=True)
        start = next((i for i, ln in enumerate(text) if re.match(rf"^{key}\s*:", ln)), None)
        if start is None:
            return "".join(text) + ("" if not text or text[-1].endswith("\n") else "\n") + "".join(lines)
        end = start + 1
        while end < len(text) and (not text[end].strip() or text[end][0].isspace() or
                                   text[end].lstrip().startswith("#") and text[end][0].isspace()):
            end += 1
        # keep a trailing comment line of the block that belongs to the next key
        return "".join(text[:start] + lines + text[end:])

    def _commit(self, text: str) -> bool:
        try:
            style = parse_style_text(text, self.path)
        except MenagerieError as exc:
            self.message = f"not applied: {exc}"
            return False
        self._texts.append(text)
        self.style = style
        self.message = ""
        if self.walking:
            self._apply_style()
        return True

    def set_cell(self, row: int, field: str, value: float) -> bool:
        """Set one number of the speed table (``SPEED_FIELDS``); False (with ``message``)
        when the style would not read back."""
        if field not in SPEED_FIELDS:
            raise MenagerieError(f"unknown speed field {field!r} (known: {', '.join(SPEED_FIELDS)})")
        rows = self.rows()
        rows[row][SPEED_FIELDS.index(field)] = float(value)
        lines = ["speeds:\n"] + ["  - {" + ", ".join(f"{f}: {float(v)!r}" for f, v in zip(SPEED_FIELDS, r,
                                                                                          strict=True)) + "}\n"
                                 for r in rows]
        return self._commit(self._replace_block("speeds", lines))

    def set_arc(self, field: str, value: float) -> bool:
        arc = self.arc()
        if arc is None:
            raise MenagerieError(f"{self.path}: the flight path is a curve, not an arc")
        if field not in arc:
            raise MenagerieError(f"unknown arc field {field!r} (known: peak, lead, pitch)")
        arc[field] = float(value)
        lines = ["flight:\n", "  arc: {" + ", ".join(f"{k}: {v!r}" for k, v in arc.items()) + "}\n"]
        return self._commit(self._replace_block("flight", lines))

    def undo(self) -> bool:
        if len(self._texts) == 1:
            return False
        self._texts.pop()
        self.style = parse_style_text(self.text, self.path)
        if self.walking:
            self._apply_style()
        return True

    def save(self, path: str | None = None, *, overwrite: bool = False) -> str:
        p = path or self.path
        if p != self.path and os.path.exists(p) and not overwrite:
            raise FileExistsError(f"{p} exists; choose another name or overwrite it explicitly")
        if os.path.exists(p):
            shutil.copy2(p, p + ".bak")
        tmp = p + ".saving"
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(self.text)
        os.replace(tmp, p)
        self.saved_text = self.text
        self.path = p
        self.message = f"saved {p}"
        return p

    # -- the walking preview --------------------------------------------------------------------

    def set_walking(self, on: bool) -> None:
        self.walking = bool(on)
        self._walked = 0.0
        for item in self.preview.items:
            ch = item.character
            if item.creature.nleg == 0:
                continue
            if on:
                self._apply_style()
            elif ch.gait is not None:
                ch.locomote((0.0, 0.0))

    def _apply_style(self) -> None:
        for item in self.preview.items:
            if item.creature.nleg == 0:
                continue
            ch = item.character
            ch.locomote((self.speed * _leg_length(item.creature), 0.0))
            ch.gait.set_style(self.style)

    def update(self, dt: float) -> None:
        """Keep the creatures walking at ``speed``; bring them back every ``WALK_SECONDS``."""
        if not self.walking:
            return
        self._walked += dt
        for item in self.preview.items:
            if item.creature.nleg:
                item.character.locomote((self.speed * _leg_length(item.creature), 0.0))
        if self._walked >= WALK_SECONDS:
            self._walked = 0.0
            for item in self.preview.items:
                if item.creature.nleg:
                    item.character.set_placement((0.0, 0.0, 0.0), 0.0, teleport=True)


def _leg_length(creature) -> float:
    legs = [float(creature.body_limb_length[f]) for f in creature.bodies_with("foot")]
    return max(legs) if legs else float(creature.height)
