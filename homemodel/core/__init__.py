"""The ground every package stands on: errors, atomic writes, bounded input files, YAML
specs, safe XML, transforms, progress and image reading. Imports nothing of homemodel above it."""
