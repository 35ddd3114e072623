# Reads CSVs as docs/outputs.md says a researcher reads them: with readr::read_csv, and with
# base R's read.csv giving its boolean columns `colClasses = "logical"`. Arguments come in
# pairs: a file, then its boolean columns joined by commas ("-" for none). Prints one line
# per column: file, column, read.csv's class, readr's class, and whether every value is
# missing; for seed columns, the values as readr read them (exact decimal text); and any
# parsing problem readr reports.
suppressPackageStartupMessages(library(readr))
args <- commandArgs(trailingOnly = TRUE)
for (k in seq(1, length(args), by = 2)) {
  f <- args[k]
  bools <- if (args[k + 1] == "-") character(0) else strsplit(args[k + 1], ",")[[1]]
  classes <- setNames(rep("logical", length(bools)), bools)
  b <- read.csv(f, stringsAsFactors = FALSE, check.names = FALSE, colClasses = classes)
  r <- read_csv(f, show_col_types = FALSE, guess_max = Inf, progress = FALSE)
  p <- problems(r)
  if (nrow(p) > 0) cat("PROBLEM", f, format(p[1, ]), sep = "\t", "\n")
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
