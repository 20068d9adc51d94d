"""The model folder, the contract between the pipelines and everything that consumes their
output (the database, the web page, the add-on, the map): `write` exports a model through
`homemodel.exchange`, runs the validation `gate` on what was written and writes summary.json,
in one atomic folder; `asset_import` and `repair` turn an asset someone already has into one;
`map_entry` registers a folder into a map file; `result` is what every pipeline entry returns.

It sits above `homemodel.exchange` (it writes and reads through the formats) and below the
pipelines (every one of them ends here); see the layers in setup.cfg.
"""
