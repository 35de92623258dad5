"""The Lambda entry points: thin handlers over the routes (``push``, ``pull``, ``admin``,
``card``), the announcer (``notify``) and their wiring.

Each handler module builds its resolver once per container, with only its own routes (see
:mod:`drboard_functions.routes`); ``lambda_handler`` only adds its decorators (the collector's,
below, the logger and the metrics), puts the service in the resolver's context and resolves the
event.

Tracing is Lambda's own (``Tracing: Active`` in template.yaml): X-Ray gets each invocation's
segment, with its initialisation, invocation and overhead, from the Lambda service, at no cost
inside the function. No tracing SDK runs in-process: patching the AWS SDK with the X-Ray SDK (in
maintenance mode since February 2026) or instrumenting it with OpenTelemetry (which Powertools'
tracer does not offer) cost a cold start 35 to 57 % of the floor a bare DynamoDB Query pays
(measured in fresh Python 3.13 processes), for a subsegment per DynamoDB call.

The cycle collector sleeps through a cold start: under the Lambda runtime it is paused from the
first import of a handler (this package) until the function's first answer is ready
(:func:`collector_after_first_answer`); then what the cold start loaded is frozen out of its way
(``gc.freeze``) and it runs again. A cold start makes 90,000 to 145,000 objects that live as long
as the container (modules, schemas, the AWS clients and their service models) and a few hundred
that are garbage (kept for the container's life); the collector would walk the living ones again
and again as they are made, a tenth of a push's cold start (measured in fresh Python 3.13
processes), and every young pass after it once more. Elsewhere (tests, `drboard serve`), importing
the handlers leaves the collector alone.
"""

from __future__ import annotations

import gc
from collections.abc import Callable
from functools import wraps
from typing import ParamSpec, TypeVar

from .wiring import in_lambda_runtime

P = ParamSpec("P")
R = TypeVar("R")

_paused = in_lambda_runtime() and gc.isenabled()
if _paused:
    gc.disable()


def collector_after_first_answer(handler: Callable[P, R]) -> Callable[P, R]:
    """The handler, running the collector again (what is loaded by then frozen) once its first
    answer is ready, where this package paused it for the cold start."""
    @wraps(handler)
    def answered(*args: P.args, **kwargs: P.kwargs) -> R:
        global _paused
        try:
            return handler(*args, **kwargs)
        finally:
            if _paused:
                _paused = False
                gc.freeze()
                gc.enable()
    return answered
