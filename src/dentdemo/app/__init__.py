"""The application shells: CLI commands, the window, the headless renderer, the Simulation."""
