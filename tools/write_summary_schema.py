"""Write the summaries' JSON Schemas (homemodel/schemas/model_summary.schema.json,
home_summary.schema.json, simulator_export.schema.json) from their pydantic models
(`homemodel.core.summary_files`); tests/test_model_summary.py fails while one is stale.

    .venv/bin/python tools/write_summary_schema.py
"""

import json

from homemodel.core.atomic import write_text_atomic
from homemodel.core.published_schema import PublishedSchema
from homemodel.core.summary_files import SUMMARY_SCHEMAS


def schema_text(published: PublishedSchema) -> str:
    return json.dumps(published.schema(), indent=2, sort_keys=True) + "\n"


if __name__ == "__main__":
    for published in SUMMARY_SCHEMAS:
        write_text_atomic(published.path(), schema_text(published))
        print(f"wrote {published.path()}")
