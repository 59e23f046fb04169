"""The HTTP and WebSocket API (docs/service.md, "Layers"; docs/howto.md, a route).

`app.create_app` builds the FastAPI app; `deps` settings, session, store, authentication
and row lookups; `schemas` the request and response models; `security` body limits and
rate limiting; `routes/` one module per resource, thin: each calls a service.
"""
