"""What the Blender extension asks of the toolkit through `homemodel addon ...`: models as
model documents, a home's map and export, and the measurement forms."""
