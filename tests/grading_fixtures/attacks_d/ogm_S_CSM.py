"""Attack: a folder tree 3,000 levels deep in the scratch folder (recursive clean-up fails)."""
import os

for _ in range(3000):
    os.mkdir("d")
    os.chdir("d")
raise SystemExit(5)
