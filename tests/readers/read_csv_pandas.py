"""Reads CSVs as docs/outputs.md says a researcher reads them with pandas: each argument pair
is a file and the dictionary's pandas expression for it (`pd.read_csv("name.csv", ...)`),
evaluated in the file's folder. Prints one line per column: file, column, dtype, and whether
every value is missing; for seed columns, the values as read (exact decimal text)."""

import os
import sys

import pandas as pd

args = sys.argv[1:]
for path, expression in zip(args[::2], args[1::2]):
    os.chdir(os.path.dirname(os.path.abspath(path)))
    frame = eval(expression, {"pd": pd})  # the documented expression, from docs/outputs.md
    for column in frame.columns:
        values = frame[column]
        print(path, column, str(values.dtype), bool(values.isna().all()), sep="\t")
        if column == "seed" or column.endswith("_seed"):
            print("SEED", path, column, ";".join(str(v) for v in values), sep="\t")
