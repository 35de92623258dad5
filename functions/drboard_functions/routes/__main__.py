"""``python -m drboard_functions.routes > functions/openapi.json``: the committed OpenAPI document."""

import sys

from .openapi import openapi_document

sys.stdout.write(openapi_document())
