"""The reference of ``bench_service.py``: a bare FastAPI app whose routes return a constant.

Served exactly like ``kinserve serve`` (uvicorn, h11, no access log), it measures what the
framework and server cost, so the service's own overhead is the difference.
"""

from fastapi import FastAPI

app = FastAPI()

CONSTANT = {"status": "ok"}


@app.get("/health")
async def health() -> dict:
    return CONSTANT


@app.post("/fk")
async def fk() -> dict:
    """Ignores the body (not even read): a request in, a constant out."""
    return CONSTANT


def main() -> None:
    """``python benchmarks/bare_app.py --port P [--workers N]``: serve this app the way ``kinserve serve``
    serves its own."""
    import argparse

    from kinserve.service.cli_serve import serve
    from kinserve.service.settings import ServiceSettings

    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("--port", type=int, required=True)
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args()
    serve("bare_app:app" if args.workers > 1 else app, ServiceSettings(), port=args.port,
          workers=args.workers, log_level="warning")


if __name__ == "__main__":
    main()
