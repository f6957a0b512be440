// A two-material skin block indented on top: 3-D linear elasticity (deal.II, Q1), written by
// DataOut as discontinuous output (every cell its own patch: 8 coincident copies per interior
// node) with SED = 1/2 sigma:eps per evaluation point, the cell-average SED from the quadrature
// points and the material id (1 = epidermis, 2 = dermis). Units: mm, N, MPa (SED in MPa).
// Built and run by make_dealii.sh; see README.md.
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/precondition.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/vector.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/data_postprocessor.h>
#include <deal.II/numerics/vector_tools.h>
#include <fstream>
#include <iostream>

using namespace dealii;
constexpr int dim = 3;

// Young's moduli (MPa) of the study's skin model (docs/method.md): epidermis 0.136, dermis 0.08; Poisson 0.48.
double lambda_of(types::material_id m) { const double E = m == 1 ? 0.136 : 0.08, nu = 0.48; return E * nu / ((1 + nu) * (1 - 2 * nu)); }
double mu_of(types::material_id m) { const double E = m == 1 ? 0.136 : 0.08, nu = 0.48; return E / (2 * (1 + nu)); }

double sed(const Tensor<2, dim> &grad, types::material_id m)
{
  const SymmetricTensor<2, dim> eps = symmetrize(grad);
  const SymmetricTensor<2, dim> sigma = lambda_of(m) * trace(eps) * unit_symmetric_tensor<dim>() + 2 * mu_of(m) * eps;
  return 0.5 * (sigma * eps);
}

class SEDPostprocessor : public DataPostprocessorScalar<dim>
{
public:
  SEDPostprocessor() : DataPostprocessorScalar<dim>("sed", update_gradients) {}
  void evaluate_vector_field(const DataPostprocessorInputs::Vector<dim> &in, std::vector<Vector<double>> &out) const override
  {
    const types::material_id m = in.template get_cell<dim>()->material_id();
    for (unsigned int q = 0; q < in.solution_gradients.size(); ++q)
    {
      Tensor<2, dim> g;
      for (unsigned int c = 0; c < dim; ++c) g[c] = in.solution_gradients[q][c];
      out[q](0) = sed(g, m);
    }
  }
};

int main()
{
  // x, z in [0, 2] mm; y in [0, 1.5] mm; dermis below y = 1 mm, epidermis above.
  Triangulation<dim> tria;
  GridGenerator::subdivided_hyper_rectangle(tria, {8, 6, 8}, Point<dim>(0, 0, 0), Point<dim>(2, 1.5, 2), true);
  for (auto &cell : tria.active_cell_iterators())
  {
    cell->set_material_id(cell->center()[1] > 1.0 ? 1 : 2);
    for (const auto f : cell->face_indices())  // the punch: |x - 1|, |z - 1| < 0.5 mm on the top face (id 3)
      if (cell->face(f)->at_boundary() && cell->face(f)->boundary_id() == 3 &&
          std::abs(cell->face(f)->center()[0] - 1) < 0.5 && std::abs(cell->face(f)->center()[2] - 1) < 0.5)
        cell->face(f)->set_boundary_id(6);
  }
  FESystem<dim> fe(FE_Q<dim>(1), dim);
  DoFHandler<dim> dofs(tria);
  dofs.distribute_dofs(fe);
  AffineConstraints<double> constraints;
  VectorTools::interpolate_boundary_values(dofs, 2, Functions::ZeroFunction<dim>(dim), constraints);  // bottom fixed
  const FEValuesExtractors::Vector u(0);
  std::vector<double> push = {0.0, -0.1, 0.0};  // the punch moves 0.1 mm down; sliding free
  VectorTools::interpolate_boundary_values(dofs, 6, Functions::ConstantFunction<dim>(push), constraints,
                                           fe.component_mask(FEValuesExtractors::Scalar(1)));
  constraints.close();
  DynamicSparsityPattern dsp(dofs.n_dofs());
  DoFTools::make_sparsity_pattern(dofs, dsp, constraints, false);
  SparsityPattern sp;
  sp.copy_from(dsp);
  SparseMatrix<double> K(sp);
  Vector<double> U(dofs.n_dofs()), F(dofs.n_dofs());
  QGauss<dim> quad(2);
  FEValues<dim> fv(fe, quad, update_gradients | update_JxW_values);
  const unsigned int n = fe.n_dofs_per_cell();
  FullMatrix<double> Ke(n, n);
  Vector<double> Fe(n);
  std::vector<types::global_dof_index> idx(n);
  for (const auto &cell : dofs.active_cell_iterators())
  {
    fv.reinit(cell);
    Ke = 0;
    Fe = 0;
    const double lam = lambda_of(cell->material_id()), mu = mu_of(cell->material_id());
    for (unsigned int q = 0; q < quad.size(); ++q)
      for (unsigned int i = 0; i < n; ++i)
        for (unsigned int j = 0; j < n; ++j)
          Ke(i, j) += (lam * fv[u].divergence(i, q) * fv[u].divergence(j, q) +
                       2 * mu * scalar_product(fv[u].symmetric_gradient(i, q), fv[u].symmetric_gradient(j, q))) * fv.JxW(q);
    cell->get_dof_indices(idx);
    constraints.distribute_local_to_global(Ke, Fe, idx, K, F);
  }
  SolverControl control(10000, 1e-12 * F.l2_norm());
  SolverCG<Vector<double>> cg(control);
  PreconditionSSOR<SparseMatrix<double>> ssor;
  ssor.initialize(K, 1.2);
  cg.solve(K, U, F, ssor);
  constraints.distribute(U);
  std::cout << "CG steps " << control.last_step() << ", dofs " << dofs.n_dofs() << std::endl;

  // Cell data: the SED averaged over the cell's Gauss points (volume-weighted), and the material id.
  Vector<double> sed_cell(tria.n_active_cells()), material(tria.n_active_cells());
  FEValues<dim> fg(fe, quad, update_gradients | update_JxW_values);
  std::vector<Tensor<2, dim>> grads(quad.size());
  for (const auto &cell : dofs.active_cell_iterators())
  {
    fg.reinit(cell);
    fg[u].get_function_gradients(U, grads);
    double e = 0, v = 0;
    for (unsigned int q = 0; q < quad.size(); ++q) { e += sed(grads[q], cell->material_id()) * fg.JxW(q); v += fg.JxW(q); }
    sed_cell[cell->active_cell_index()] = e / v;
    material[cell->active_cell_index()] = cell->material_id();
  }
  SEDPostprocessor sed_pp;
  DataOut<dim> out;
  out.attach_dof_handler(dofs);
  std::vector<DataComponentInterpretation::DataComponentInterpretation> vec(dim, DataComponentInterpretation::component_is_part_of_vector);
  out.add_data_vector(U, std::vector<std::string>(dim, "displacement"), DataOut<dim>::type_dof_data, vec);
  out.add_data_vector(U, sed_pp);
  out.add_data_vector(sed_cell, "sed_cell", DataOut<dim>::type_cell_data);
  out.add_data_vector(material, "material_id", DataOut<dim>::type_cell_data);
  out.build_patches();
  std::ofstream f("indent_block.vtu");
  out.write_vtu(f);
  return 0;
}
