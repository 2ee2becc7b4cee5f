"""The validation grid's judge: every creature x animation cell played and measured.

Spore judged its animation grid by eye (a team of testers over several hundred creatures
and a thousand animations, ~90% passing; Hecker et al. 2008, section 5). Menagerie
measures instead. A cell is one animation variant on one creature, played through
``engine.Character`` at 60 Hz exactly as a game plays it (``record``); its frames are
measured by one module per concern and judged against one table of thresholds:

    record          play a cell and keep every frame (poses, goals, weights, timing)
    continuity      pops and flips beyond what the goals ask, jitter, the clip's ends,
                    the pose it returns to
    goals           goal misses, reachable and out of reach; rotation and look-at misses
    ground          box corners below the ground; standing feet sliding
    selfcollision   boxes of one creature inside each other beyond the rest pose's
    limits          IK stretch and compression against the solver's limits
    consistency     path independence (scrubbing = playing) and mirror images
    gait            the locomotion scenario and its measures (slide, touchdown, ...)
    thresholds      the table: warn and fail per metric, with why
    cell            one creature's cells, judged (``run_creature``)
    grid            many creatures, serially or on Dask; the summary and comparisons

    from engine.validation import run_creature
    results = run_creature(engine.load_creature("creatures/humanoid.yaml"), [anim])
    results[0].status, results[0].reason, results[0].measures["rotation_pop"].value
"""

from engine.validation.cell import CellContext, CellResult, run_cell, run_creature
from engine.validation.measure import Measure
from engine.validation.record import Recording, record_cell
from engine.validation.thresholds import THRESHOLDS, verdict

__all__ = ["THRESHOLDS", "CellContext", "CellResult", "Measure", "Recording", "record_cell", "run_cell",
           "run_creature", "verdict"]
