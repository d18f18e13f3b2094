"""/docs and /redoc work offline: headless Chromium with only loopback reachable renders the endpoint list.

The Swagger UI and ReDoc scripts and styles come from the fastapi-offline
package through the service itself (``/static-offline-docs/...``); no request
leaves 127.0.0.1 and the pages find every operation of the OpenAPI schema.
"""

from __future__ import annotations

import httpx
import pytest

from kinserve.viz import find_browser

from browser_checks import open_offline
from service_server import Server

pytestmark = pytest.mark.skipif(find_browser() is None,
                                reason="no Chromium binary found (apt-get install chromium)")

SWAGGER_PATHS_JS = """(() => {
  const blocks = document.querySelectorAll('.opblock .opblock-summary-path');
  if (blocks.length === 0) return null;
  return Array.from(blocks).map(e => (e.getAttribute('data-path') || e.textContent).trim());
})()"""

REDOC_PATHS_JS = """(() => {
  const ops = document.querySelectorAll('[data-section-id^="operation/"]');
  if (ops.length === 0) return null;
  const text = document.body.innerText;
  return {operations: ops.length, text: text};
})()"""


@pytest.fixture(scope="module")
def server():
    srv = Server()
    yield srv
    srv.stop()


@pytest.fixture(scope="module")
def api_paths(server) -> set[str]:
    return set(httpx.get(server.url + "/openapi.json", timeout=10).json()["paths"])


def assert_stayed_local(requested, server):
    assert requested, "the page requested nothing"
    outside = [u for u in requested if not u.startswith((server.url + "/", "data:", "blob:", "about:"))]
    assert not outside, f"requests left the service: {outside}"


def test_docs_page_has_no_cdn_reference(server):
    page = httpx.get(server.url + "/docs", timeout=10).text
    assert "/static-offline-docs/swagger-ui-bundle.js" in page and "cdn" not in page.lower()
    js = httpx.get(server.url + "/static-offline-docs/swagger-ui-bundle.js", timeout=10)
    assert js.status_code == 200 and len(js.content) > 500_000 and "SwaggerUIBundle" in js.text[:2000]


def test_swagger_ui_lists_every_endpoint_offline(server, api_paths):
    paths, requested, errors = open_offline(server.url + "/docs", SWAGGER_PATHS_JS)
    assert {"/fk", "/ik", "/ik/batch", "/jacobian", "/plan/cartesian", "/robots/{name}"} <= api_paths
    assert set(paths) == api_paths, (paths, api_paths)
    assert_stayed_local(requested, server)
    assert server.url + "/openapi.json" in requested
    assert not errors, errors


def test_redoc_page_has_no_cdn_reference(server):
    """The ReDoc page and the script it loads name no address outside the service (the bundle's badge
    image pointed at cdn.redoc.ly: the browser fetched it whenever the sidebar rendered in time)."""
    page = httpx.get(server.url + "/redoc", timeout=10).text
    assert "/offline-docs/redoc.standalone.js" in page and "cdn" not in page.lower()
    js = httpx.get(server.url + "/offline-docs/redoc.standalone.js", timeout=10)
    assert js.status_code == 200 and len(js.content) > 500_000 and "Redoc" in js.text
    assert "cdn.redoc.ly" not in js.text and "/static-offline-docs/favicon.png" in js.text


def test_redoc_lists_every_endpoint_offline(server, api_paths):
    found, requested, errors = open_offline(server.url + "/redoc", REDOC_PATHS_JS)
    assert found["operations"] >= len(api_paths)
    for path in api_paths:
        assert path in found["text"], path
    assert_stayed_local(requested, server)
    assert not errors, errors
