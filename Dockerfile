# wheelscan: one image for the API and the measurement workers (see docker-compose.yml).
#   api:    wheelscan serve --host 0.0.0.0
#   worker: wheelscan worker --concurrency 1     (one per core; scale with --scale worker=N)
FROM python:3.11-slim-bookworm

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1

# Fonts for the PDF reports; OpenCV is the headless build and needs no X or GL libraries.
RUN apt-get update \
    && apt-get install -y --no-install-recommends fonts-dejavu-core \
    && rm -rf /var/lib/apt/lists/*

WORKDIR /app
COPY pyproject.toml requirements.lock README.md ./
COPY pipeline ./pipeline
COPY db ./db
COPY backend ./backend
RUN pip install -c requirements.lock . \
    && cd / && python -m pipeline.precompile  # the installed package, as the CLI imports it
COPY frontend ./frontend

RUN useradd --system --uid 10001 --home-dir /data wheelscan \
    && mkdir -p /data \
    && chown wheelscan /data
USER wheelscan

# /data holds the frame store (a volume shared by api and workers) and worker caches.
ENV WHEELSCAN_DATA_DIR=/data \
    WHEELSCAN_FRONTEND_DIR=/app/frontend \
    WHEELSCAN_HOST=0.0.0.0
VOLUME ["/data"]
EXPOSE 8000
CMD ["wheelscan", "serve"]
