"""Where the tests find the shared data sets: beside the repository (``../shared/``), or where an environment
variable says. Tests that need one skip with a message when it is absent (a user's clone)."""

from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: The MotionBenchMaker Panda problems (VAMP's resources/panda/): ``$KINSERVE_MBM_DATASET`` or
#: ``../shared/datasets/motion-bench-maker`` beside the repository.
MBM_DATASET = Path(os.environ.get("KINSERVE_MBM_DATASET",
                                  ROOT.parent / "shared" / "datasets" / "motion-bench-maker"))
