// The diagnosis pipeline and the identification, instantiated once for the project's programs.
//
// Their functions are templates on an unused parameter (template <typename = void>): a
// template's body is compiled only where it is called, so a file that includes the headers pays
// for what it uses (a file that includes sid/cvode/diagnose.hpp and calls nothing: 14.6 s of
// front end instead of 41.8 s). The apps, the diagnosis tests and the diagnosis bench link this
// library, which defines SID_PRECOMPILED for them: the headers then declare their top functions
// `extern template`, and those files do not compile them at all. A user's program includes the
// same headers without the macro and gets ordinary header-only code.
#include <sid/cvode/diagnose.hpp>
#include <sid/cvode/free_simulation.hpp>
#include <sid/cvode/friction_refinement.hpp>
#include <sid/cvode/output_error.hpp>
#include <sid/diagnose.hpp>
#include <sid/identify.hpp>

namespace sid {

template DiagnosisResult diagnose<>(const Trajectory<double>&, const DiagnoseOptions&);
template DiagnosisResult diagnose_with_simulation<>(const Trajectory<double>&, const DiagnoseOptions&,
                                                    const FreeSimulationOptions&, const SimulationCheckOptions&,
                                                    SimulationCheck*);
template FrictionRefinement refine_friction<>(const DiagnosisResult&, const Trajectory<double>&, int,
                                              const FrictionRefinementOptions&);
template void refine_named_friction<>(DiagnosisResult&, const Trajectory<double>&, const DiagnoseOptions&,
                                      FrictionRefinementOptions);
template OutputErrorFit fit_output_error<>(const OutputErrorProblem&, const OutputErrorOptions&);
template OutputErrorScore output_error_score_test<>(const OutputErrorProblem&, const OutputErrorFit&,
                                                    const Model<double>&, const Eigen::VectorXd&, Eigen::Index,
                                                    double, const OutputErrorOptions&);
template FreeSimulation free_simulation<>(const Model<double>&, const Eigen::Ref<const Eigen::VectorXd>&,
                                          const Kinematics<double>&, const FreeSimulationOptions&);
template Identification identify<>(const Trajectory<double>&, const IdentifyOptions&);

}  // namespace sid
