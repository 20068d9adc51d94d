"""The summary files homemodel's output folders hold, each under its own name with its own
published schema: summary.json is a model folder's, always (`model_summary`); a home's table
of objects is home_summary.json (`home_summary`); a simulator export's is export_summary.json
(`export_summary`). A client picks the schema by the file's name."""

from __future__ import annotations

from homemodel.core.export_summary import EXPORT_SUMMARY
from homemodel.core.home_summary import HOME_SUMMARY
from homemodel.core.model_summary import MODEL_SUMMARY
from homemodel.core.published_schema import PublishedSchema

SUMMARY_SCHEMAS: tuple[PublishedSchema, ...] = (MODEL_SUMMARY, HOME_SUMMARY, EXPORT_SUMMARY)
