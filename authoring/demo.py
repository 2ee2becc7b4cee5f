"""``menagerie demo``: a zoo of library creatures, each playing the library's animations in
turn, ticked together as one ``Crowd``, with the cost per character on screen.

With a display it opens the viewer (arrow keys step through the creatures one at a
time). Without one, or with ``--headless``, it renders the frames offscreen and writes a
contact sheet ``OUT/contact_sheet.png``, the frames ``OUT/frame_NNN.png`` it sampled, a
GIF ``OUT/demo.gif`` when pillow is installed (the ``media`` or ``dev`` extra), and
prints the timing.
"""

from __future__ import annotations

import glob
import os
import time

import numpy as np

from engine.paths import LIBRARY_ANIMATIONS, LIBRARY_CREATURES

#: The creatures the demo shows: one of each kind of body plan.
DEMO_CREATURES = ("humanoid", "dog", "horse", "spider", "hexapod", "centaur", "octopus", "bird", "twoheaded",
                  "threearmed", "trex", "kangaroo", "elephant", "snake", "fish", "mantis")
#: Seconds each animation plays before the next cross-fades in.
TURN = 2.4
FADE = 0.35


def library_creatures(names=DEMO_CREATURES):
    import engine

    out = []
    for n in names:
        path = os.path.join(LIBRARY_CREATURES, f"{n}.yaml")
        if os.path.exists(path):
            out.append(engine.load_creature(path))
    return out


def library_animations():
    from engine.anim import load_animation

    return [load_animation(p) for p in sorted(glob.glob(os.path.join(LIBRARY_ANIMATIONS, "*.yaml")))]


class Zoo:
    """The demo's world: characters, their playlists, the crowd and the scene."""

    def __init__(self, creatures, animations) -> None:
        import engine
        from authoring import scene as sc
        from engine.anim.binding import branch_failures

        self.zoo = sc.layout_zoo(creatures, normalize_size=True, labels=True)
        self.characters = []
        self.playlists = []
        for k, (c, actor) in enumerate(zip(creatures, self.zoo.actors, strict=True)):
            ch = engine.Character(c)
            playable = [a for a in animations if not branch_failures(a, c)]
            # Start each creature somewhere different in the library so the zoo is varied.
            shift = (3 * k) % max(len(playable), 1)
            self.playlists.append(playable[shift:] + playable[:shift])
            self.characters.append(ch)
            actor.base_label = actor.label
        self.crowd = engine.Crowd(self.characters)
        self.turn = [0] * len(self.characters)
        self.clock = 0.0
        self.next_switch = 0.0
        self.tick_ms: list[float] = []

    def _switch(self) -> None:
        for k, ch in enumerate(self.characters):
            plist = self.playlists[k]
            if not plist:
                continue
            anim = plist[self.turn[k] % len(plist)]
            self.turn[k] += 1
            b = ch.binding(anim)
            variant = self.turn[k] % b.nvariant
            # Targets a little in front of each creature, at chest height.
            h = ch.creature.height
            for name in anim.target_names:
                ch.set_target(name, (0.7 * h, 0.25 * h, 0.7 * h))
            ch.play(anim, variant=variant, fade=FADE, loop=True)

    def step(self, dt: float) -> None:
        if self.clock >= self.next_switch:
            self._switch()
            self.next_switch += TURN
        t = time.perf_counter()
        self.crowd.tick(dt)
        self.tick_ms.append((time.perf_counter() - t) * 1e3)
        self.clock += dt
        for ch, actor in zip(self.characters, self.zoo.actors, strict=True):
            actor.set_pose(ch.world_positions, ch.world_rotations)
            playing = [h.animation.name for h, _, w in ch.player.active() if w > 0.5]
            actor.label = f"{actor.base_label}\n{playing[0] if playing else ''}"
        per_char = np.median(self.tick_ms[-60:]) / len(self.characters)
        self.zoo.caption = (f"Menagerie  {len(self.characters)} creatures  "
                            f"{per_char:.3f} ms per character per frame  t={self.clock:.1f} s")


def run_demo(headless: bool = False, out_dir: str = "out/demo", seconds: float = 4.0) -> int:
    from authoring import render as rd

    started = time.perf_counter()
    zoo = Zoo(library_creatures(), library_animations())
    print(f"menagerie demo: {len(zoo.characters)} creatures, {sum(map(len, zoo.playlists))} playable "
          f"(creature, animation) pairs, set up in {time.perf_counter() - started:.2f} s")
    if headless or rd.want_headless():
        return _headless(zoo, out_dir, seconds)
    from authoring.viewer import view

    view(zoo.zoo, update=zoo.step, title="Menagerie demo", instead=f"menagerie demo --headless --out {out_dir}")
    return 0


def _headless(zoo: Zoo, out_dir: str, seconds: float, fps: int = 30, sheet_frames: int = 6) -> int:
    from authoring import render as rd

    os.makedirs(out_dir, exist_ok=True)
    nframe = max(int(round(seconds * fps)), 1)
    keep = set(np.linspace(0, nframe - 1, sheet_frames).round().astype(int).tolist())
    frames = []
    gif_frames = []
    with rd.Renderer(960, 540) as renderer:
        camera = None
        for f in range(nframe):
            zoo.step(1.0 / fps)
            if f == 0:
                camera = renderer.frame(zoo.zoo)
                camera.zoom(1.1)   # room for the caption above the back row
            renderer.draw(zoo.zoo, camera)
            rgb = renderer.read_pixels()
            if f in keep:
                path = os.path.join(out_dir, f"frame_{f:03d}.png")
                rd.write_png(path, rgb)
                frames.append(rgb.copy())
            if f % 2 == 0:
                gif_frames.append(rgb[::2, ::2].copy())
    sheet = _contact_sheet(frames, columns=3)
    sheet_path = os.path.join(out_dir, "contact_sheet.png")
    rd.write_png(sheet_path, sheet)
    print(f"menagerie demo: wrote {sheet_path} and {len(frames)} frames to {out_dir}")
    try:
        from PIL import Image
    except ImportError:
        print("menagerie demo: pillow is not installed (pip install -e '.[media]'): no GIF")
    else:
        images = [Image.fromarray(g) for g in gif_frames]
        gif = os.path.join(out_dir, "demo.gif")
        images[0].save(gif, save_all=True, append_images=images[1:], duration=int(2000 / fps), loop=0)
        print(f"menagerie demo: wrote {gif}")
    ms = np.array(zoo.tick_ms[5:] or zoo.tick_ms)
    n = len(zoo.characters)
    print(f"menagerie demo: crowd tick median {np.median(ms):.3f} ms for {n} characters = "
          f"{np.median(ms) / n:.4f} ms per character per frame")
    return 0


def _contact_sheet(frames: list[np.ndarray], columns: int) -> np.ndarray:
    h, w, _ = frames[0].shape
    rows = (len(frames) + columns - 1) // columns
    sheet = np.full((rows * h, columns * w, 3), 255, np.uint8)
    for k, f in enumerate(frames):
        r, c = divmod(k, columns)
        sheet[r * h:(r + 1) * h, c * w:(c + 1) * w] = f
    return sheet
