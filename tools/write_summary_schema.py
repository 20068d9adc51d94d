"""Write homemodel/schemas/model_summary.schema.json from the summary's pydantic model
(`homemodel.core.model_summary`); tests/test_model_summary.py fails while it is stale.

    .venv/bin/python tools/write_summary_schema.py
"""

import json

from homemodel.core.atomic import write_text_atomic
from homemodel.core.model_summary import schema_path, summary_schema


def schema_text() -> str:
    return json.dumps(summary_schema(), indent=2, sort_keys=True) + "\n"


if __name__ == "__main__":
    write_text_atomic(schema_path(), schema_text())
    print(f"wrote {schema_path()}")
