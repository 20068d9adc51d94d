"""The Blender extension for installers. Not built yet: its issue has not landed."""
