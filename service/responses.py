"""JSON answers of the service: compact, and never a non-finite number.

Every endpoint returns :func:`json_response` of plain Python data. The
encoder refuses NaN and infinities (``allow_nan=False``); a result that holds
one becomes a 422 error answer naming the problem instead of a 500 or a
``null`` where a number was promised. The causes are fixed where they arise
(bounded models and inputs); this is the guard that keeps the promise
"every number in a response is finite" even for a cause not yet found.
"""

from __future__ import annotations

import json
import math

from starlette.responses import Response

_encode = json.JSONEncoder(allow_nan=False, separators=(",", ":"), ensure_ascii=False).encode


def error_body(loc: list, msg: str, kind: str) -> dict:
    """The error document of every 4xx/5xx answer: ``{"detail": [{"loc", "msg", "type"}]}``."""
    return {"detail": [{"loc": loc, "msg": msg, "type": kind}]}


def json_safe(value):
    """``value`` with NaN/inf floats as strings and unknown objects as ``str``: always JSON-encodable."""
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    if isinstance(value, (str, int, bool)) or value is None:
        return value
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return str(value)


def json_response(payload, status_code: int = 200, headers: dict | None = None) -> Response:
    """``payload`` (lists, dicts, floats, ...) as a JSON answer; 422 ``NonFiniteResult`` if it holds NaN/inf."""
    try:
        body = _encode(payload)
    except ValueError:
        body = _encode(error_body(
            ["body"], "the result holds a non-finite number (NaN or infinity) and cannot be answered; "
            "the request's model or inputs are numerically degenerate", "NonFiniteResult"))
        status_code = 422
    return Response(body.encode(), status_code=status_code, headers=headers, media_type="application/json")
