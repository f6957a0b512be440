// Regenerate tests/data/dealii/ (see README.md there): deal.II 9.4.1 writing parallel VTU records.
//
// A 4 x 4 x 2 mm block (coordinates in mm) of 8 x 8 x 4 hexahedra, Q1 elements, partitioned over
// 2 MPI ranks (parallel::shared::Triangulation). Each rank writes its locally owned cells with
// DataOut::write_vtu_with_pvtu_record (one .vtu piece per rank, one .pvtu record per step); rank 0
// writes the .pvd listing the steps with their times (DataOutBase::write_pvd_record). The field
// "sed" is an indentation-like strain-energy density in MPa interpolated into the Q1 space,
// SED(x, y, z, t) = 1e-4 t exp(-((x-2)^2 + (y-2)^2) / 0.5) (z / 2)^2, continuous, so the nodes the
// two pieces share carry the same values. Steps t = 0.5 and 1.0 s.
//
// Build and run (Debian packages libdeal.ii-dev 9.4.1, openmpi):
//   mpicxx -std=c++17 -O1 -I/usr/include/trilinos -I/usr/include/suitesparse -I/usr/include/petsc \
//       -I/usr/include/slepc make_pvtu.cc -o /tmp/make_pvtu -Wl,--copy-dt-needed-entries -ldeal.ii
//   mpirun --allow-run-as-root --oversubscribe -np 2 /tmp/make_pvtu
#include <deal.II/base/function.h>
#include <deal.II/base/mpi.h>
#include <deal.II/distributed/shared_tria.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/lac/vector.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/vector_tools.h>

#include <cmath>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

using namespace dealii;

class IndentSED : public Function<3>
{
public:
  explicit IndentSED(const double t) : Function<3>(1), t(t) {}
  double value(const Point<3> &p, const unsigned int = 0) const override
  {
    const double r2 = (p[0] - 2) * (p[0] - 2) + (p[1] - 2) * (p[1] - 2);
    return 1e-4 * t * std::exp(-r2 / 0.5) * (p[2] / 2) * (p[2] / 2);
  }
private:
  double t;
};

int main(int argc, char **argv)
{
  Utilities::MPI::MPI_InitFinalize mpi(argc, argv, 1);
  const MPI_Comm comm = MPI_COMM_WORLD;
  parallel::shared::Triangulation<3> tria(comm);
  GridGenerator::subdivided_hyper_rectangle(tria, {8, 8, 4}, Point<3>(0, 0, 0), Point<3>(4, 4, 2));
  FE_Q<3> fe(1);
  DoFHandler<3> dofs(tria);
  dofs.distribute_dofs(fe);
  std::vector<std::pair<double, std::string>> records;
  const double times[] = {0.5, 1.0};
  for (unsigned int step = 0; step < 2; ++step)
    {
      Vector<double> sed(dofs.n_dofs());
      VectorTools::interpolate(dofs, IndentSED(times[step]), sed);
      DataOut<3> out;
      out.attach_dof_handler(dofs);
      out.add_data_vector(sed, "sed");
      out.build_patches();
      const std::string pvtu = out.write_vtu_with_pvtu_record("./", "block", step, comm, 2);
      records.emplace_back(times[step], pvtu);
    }
  if (Utilities::MPI::this_mpi_process(comm) == 0)
    {
      std::ofstream pvd("block.pvd");
      DataOutBase::write_pvd_record(pvd, records);
    }
}
