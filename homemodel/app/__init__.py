"""What the command line and the Blender add-on drive: home builds from a home's specs."""
