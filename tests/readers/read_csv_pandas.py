"""Reads CSVs as docs/outputs.md says a researcher reads them with pandas: each argument pair
is a file and the dictionary's pandas expression for it (`pd.read_csv("name.csv", ...)`),
evaluated in the file's folder. Prints one line per column: file, column, dtype, and whether
every value is missing; for seed columns, the values as read (exact decimal text); and a KEPT
line per file: the cells, and how many are missing in pandas but not empty in the file, or
the other way round (0: every value kept, only empty fields missing)."""

import os
import sys

import pandas as pd

args = sys.argv[1:]
home = os.getcwd()
for path, expression in zip(args[::2], args[1::2]):
    path = os.path.abspath(path)
    os.chdir(os.path.dirname(path))
    frame = eval(expression, {"pd": pd})  # the documented expression, from docs/outputs.md
    os.chdir(home)
    # The file's own text: every field as written, nothing taken for missing.
    raw = pd.read_csv(path, dtype=str, keep_default_na=False)
    lost = int((frame.isna().to_numpy() != (raw == "").to_numpy()).sum())
    print("KEPT", path, "pandas", raw.size, lost, sep="\t")
    print("ROWS", path, len(frame), sep="\t")
    for column in frame.columns:
        values = frame[column]
        print(path, column, str(values.dtype), bool(values.isna().all()), sep="\t")
        if column == "seed" or column.endswith("_seed"):
            print("SEED", path, column, ";".join(str(v) for v in values), sep="\t")
