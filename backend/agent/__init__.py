"""The station capture agent: wayside cameras → labelled frames → the server's streaming API.

It runs next to the cameras and talks to the server only through the public streaming API
(README, 'Live-streaming protocol'): station file (`station`), camera sources (`cameras`, pypylon),
trigger sequence → labels (`axles`), capture loop (`capture`), local disk buffer (`spool`),
uploader (`uploader`, `client`), terminal progress (`progress`), and emulated-camera replay
of a pass archive for tests and demos (`replay`). `runner.run_agent` wires them together.
The station file's keys: docs/formats.md, "Station file".
"""
