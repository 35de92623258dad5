"""The Lambda entry points: thin handlers over the routes (``push``, ``pull``, ``admin``,
``card``), the announcer (``notify``) and their wiring.

Each handler module builds its resolver once per container, with only its own routes (see
:mod:`drboard_functions.routes`); ``lambda_handler`` only adds the observability decorators (the
logger and the metrics), puts the service in the resolver's context and resolves the event.

Tracing is Lambda's own (``Tracing: Active`` in template.yaml): X-Ray gets each invocation's
segment, with its initialisation, invocation and overhead, from the Lambda service, at no cost
inside the function. No tracing SDK runs in-process: patching the AWS SDK with the X-Ray SDK (in
maintenance mode since February 2026) or instrumenting it with OpenTelemetry (which Powertools'
tracer does not offer) cost a cold start 35 to 57 % of the floor a bare DynamoDB Query pays
(measured in fresh Python 3.13 processes), for a subsegment per DynamoDB call.
"""
