"""A full mesh of a new object from one depth image (Rock et al. 2015, D3.1 section 3.3.3).

Matching (`features`, `shape_codes`, `matching`), Fitting (`spin_images`, `registration`,
`symmetry`, `deformation`) and Filling (`filling`) are tied together by
`pipeline.ShapeCompleter`; `library` and `procedural` provide the class library,
`model_io` saves models, `benchmark` runs D3.1 Table 1's protocol. See docs/shape_completion.md.
"""
