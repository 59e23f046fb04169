"""The frame store: content-addressed blobs (docs/service.md, "Storage").

`store.BlobStore` on a local disk, `remote` the same over HTTP for workers without it,
`artefacts` the extraction artefacts of a frame.
"""
