"""A home's build: its `home.yaml` (rooms, objects and their specs) into validated model
folders and one semantic map."""
