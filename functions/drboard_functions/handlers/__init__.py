"""The Lambda entry points: thin handlers over the routes (``push``, ``pull``, ``admin``,
``card``), the announcer (``notify``) and their wiring.

Each handler module builds its resolver once per container; ``lambda_handler`` only adds the
observability decorators, puts the service in the resolver's context and resolves the event.
"""
