"""The values options offer, written out so that a command's --help imports no model.
A unit test holds each equal to the model it comes from."""

from __future__ import annotations

#: drboard_assembler.record.RaceType
RACE_TYPES = ("TIME_TRIAL", "OBJECT_AVOIDANCE", "HEAD_TO_BOT", "HEAD_TO_MODEL",
              "HEAD_TO_HEAD_RACING", "F1")
#: drboard_functions.models.TimingMethod
TIMING_METHODS = ("BEST_LAP_TIME", "AVG_LAP_TIME", "TOTAL_TIME")
#: drboard_functions.models.MAX_COOLDOWN_S: a week
MAX_COOLDOWN_S = 7 * 24 * 3600
