"""Responses to a load ramp: stable branches, force-controlled tests with their snaps,
quasi-static and dynamic ramps, and their summaries (main "Application")."""
