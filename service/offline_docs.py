"""The ReDoc page, offline: its script served with the one address it would fetch from the internet replaced.

``fastapi_offline`` serves Swagger UI's and ReDoc's scripts from the package (``/static-offline-docs``), but
ReDoc's bundle still draws its "API docs by Redocly" badge from ``https://cdn.redoc.ly``: a browser without
internet (or a test that allows only loopback) sees a request leave the service, sooner or later depending
on how fast the page renders. Here ``/redoc`` loads the same bundle from
``/offline-docs/redoc.standalone.js``, read once when the app is made, with the badge's image pointed at the
package's own favicon.
"""

from __future__ import annotations

from pathlib import Path

import fastapi_offline
from fastapi import FastAPI, Request
from fastapi.openapi.docs import get_redoc_html
from starlette.responses import HTMLResponse, Response

#: The address in ReDoc's bundle that leaves the service.
REDOC_BADGE = "https://cdn.redoc.ly/redoc/logo-mini.svg"
STATIC = "/static-offline-docs"  # fastapi_offline's mount
SCRIPT = "/offline-docs/redoc.standalone.js"


def redoc_script() -> str:
    """ReDoc's standalone bundle from ``fastapi_offline`` with :data:`REDOC_BADGE` replaced by the
    package's favicon (served at ``STATIC/favicon.png``)."""
    path = Path(fastapi_offline.__file__).parent / "static" / "redoc.standalone.js"
    return path.read_text(encoding="utf-8").replace(REDOC_BADGE, f"{STATIC}/favicon.png")


def add_redoc(app: FastAPI, url: str = "/redoc") -> None:
    """Serve the offline ReDoc page at ``url`` and its script at :data:`SCRIPT` (the app was made with
    ``FastAPIOffline(redoc_url=None)``)."""
    script = redoc_script()

    @app.get(SCRIPT, include_in_schema=False)
    async def redoc_standalone() -> Response:
        return Response(script, media_type="application/javascript")

    @app.get(url, include_in_schema=False)
    async def redoc_html(request: Request) -> HTMLResponse:
        root = request.scope.get("root_path", "")
        return get_redoc_html(openapi_url=f"{root}{app.openapi_url}", title=f"{app.title} - ReDoc",
                              redoc_js_url=f"{root}{SCRIPT}", with_google_fonts=False,
                              redoc_favicon_url=f"{root}{STATIC}/favicon.png")
