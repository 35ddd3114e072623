# Reads CSVs as docs/outputs.md says a researcher reads them: arguments come in triples, a
# file, then its Read line's readr call and its read.csv call, evaluated in the file's folder.
# Prints one line per column: file, column, read.csv's class, readr's class, and whether every
# value is missing; for seed columns, the values as readr read them (exact decimal text); any
# parsing problem readr reports; and a KEPT line per file and reader: the cells, and how many
# of them are missing in R but not empty in the file, or the other way round (0: every value
# kept, only empty fields missing); a ROWS line per file (a table without rows has no types to
# check).
suppressPackageStartupMessages(library(readr))
args <- commandArgs(trailingOnly = TRUE)
home <- getwd()
for (k in seq(1, length(args), by = 3)) {
  f <- normalizePath(args[k])
  setwd(dirname(f))
  r <- eval(parse(text = args[k + 1]))
  b <- eval(parse(text = args[k + 2]))
  setwd(home)
  p <- problems(r)
  if (nrow(p) > 0) cat("PROBLEM", f, format(p[1, ]), sep = "\t", "\n")
  # The file's own text: every field as written, nothing taken for missing.
  raw <- read.csv(f, colClasses = "character", na.strings = character(0), check.names = FALSE)
  for (reader in list(list("readr", r), list("read.csv", b))) {
    frame <- reader[[2]]
    lost <- 0
    for (col in names(raw)) lost <- lost + sum(is.na(frame[[col]]) != (raw[[col]] == ""))
    cat("KEPT", f, reader[[1]], nrow(raw) * ncol(raw), lost, sep = "\t")
    cat("\n")
  }
  cat("ROWS", f, nrow(b), sep = "\t")
  cat("\n")
  for (col in names(b)) {
    v <- b[[col]]
    empty <- all(is.na(v) | (is.character(v) & v == ""))
    cat(f, col, class(v)[1], class(r[[col]])[1], empty, sep = "\t")
    cat("\n")
    if (col == "seed" || endsWith(col, "_seed")) {
      cat("SEED", f, col, paste(sprintf("%.0f", r[[col]]), collapse = ";"), sep = "\t")
      cat("\n")
    }
  }
}
