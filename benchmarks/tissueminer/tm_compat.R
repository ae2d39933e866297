## Run one of TissueMiner's Rscripts with the small shims that Debian's R packages need.
## Usage: Rscript tm_compat.R $TM_HOME/shear/CalculateShearContributions.R <movie_dir>
## (commandArgs(TRUE) seen by the sourced script: everything after the script path).
##
## Shims (TissueMiner was written for dplyr 0.4-0.7 / dtplyr 0.0.x; Debian 12 ships dplyr 1.0.10, dtplyr 1.2.2):
##  * tbl_dt(): removed from dtplyr >= 1.0.  TissueMiner uses it only to speed up a group_by/filter
##    in assignROI(); the identity gives the same rows.
options(warn = 1)  # print warnings as they occur (into the log)
args <- commandArgs(TRUE)
script <- args[1]
if (!exists("tbl_dt")) tbl_dt <- function(x, ...) x
## the sourced script reads its own arguments with commandArgs(TRUE): drop the script path
commandArgs <- function(trailingOnly = FALSE) if (trailingOnly) args[-1] else c(base::commandArgs(FALSE))
source(script, echo = FALSE)
