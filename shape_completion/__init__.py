"""A full mesh of a new object from one depth image (Rock et al. 2015, D3.1 section 3.3.3). Not built yet: its issue has not landed."""
