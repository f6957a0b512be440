#!/bin/sh
# Build and run indent_block.cc with deal.II 9.4.1 of Debian 12 ('apt-get install libdeal.ii-dev'):
# the include directories are those deal.IIConfig.cmake lists. Writes indent_block.vtu here.
set -e
cd "$(dirname "$0")"
INC=$(sed -n 's/^SET(DEAL_II_INCLUDE_DIRS "\${DEAL_II_PATH}\/\${DEAL_II_INCLUDE_RELDIR};\(.*\)")$/\1/p' \
      /usr/share/cmake/deal.II/deal.IIConfig.cmake | tr ';' '\n' | sed 's/^/-I/' | tr '\n' ' ')
g++ -std=c++17 -O1 -o /tmp/indent_block indent_block.cc $INC -ldeal.ii -ltrilinos_teuchoscomm -ltrilinos_teuchoscore -ltbb -lmpi_cxx -lmpi
/tmp/indent_block
