#include "omnipoint/model/state_dict.h"

#include <ATen/ATen.h>
#include <torch/nn/module.h>
#include <torch/utils.h>

#include <sstream>
#include <stdexcept>

namespace omnipoint::model {
namespace {

constexpr std::size_t kMaxListedNames = 10;

std::string shape_string(at::IntArrayRef sizes) {
  std::ostringstream out;
  out << sizes;
  return out.str();
}

// "3 missing (a, b, c)", at most kMaxListedNames names then "... and N more".
void describe(std::ostringstream& out, const char* what, const std::vector<std::string>& items) {
  out << "; " << items.size() << ' ' << what << " (";
  for (std::size_t i = 0; i < items.size() && i < kMaxListedNames; ++i)
    out << (i ? ", " : "") << items[i];
  if (items.size() > kMaxListedNames)
    out << ", ... and " << items.size() - kMaxListedNames << " more";
  out << ')';
}

}  // namespace

std::map<std::string, at::Tensor> state_dict(const torch::nn::Module& module) {
  std::map<std::string, at::Tensor> out;
  for (const auto& item : module.named_parameters(/*recurse=*/true))
    out[item.key()] = item.value().detach();
  for (const auto& item : module.named_buffers(/*recurse=*/true))
    out[item.key()] = item.value().detach();
  return out;
}

LoadReport load_state_dict(torch::nn::Module& module,
                           const std::map<std::string, at::Tensor>& tensors, LoadMode mode,
                           LoadStorage storage) {
  std::map<std::string, at::Tensor> targets;
  for (const auto& item : module.named_parameters(/*recurse=*/true))
    targets[item.key()] = item.value();
  for (const auto& item : module.named_buffers(/*recurse=*/true))
    targets[item.key()] = item.value();

  LoadReport report;
  std::vector<std::string> mismatch_details;
  for (const auto& [name, target] : targets) {
    const auto source = tensors.find(name);
    if (source == tensors.end() || !source->second.defined()) {
      report.missing.push_back(name);
    } else if (source->second.sizes() != target.sizes()) {
      report.mismatched.push_back(name);
      mismatch_details.push_back(name + ": given " + shape_string(source->second.sizes()) +
                                 ", module has " + shape_string(target.sizes()));
    } else {
      report.loaded.push_back(name);
    }
  }
  for (const auto& [name, tensor] : tensors) {
    if (targets.count(name) == 0) report.unexpected.push_back(name);
  }

  if (mode == LoadMode::kStrict &&
      (!report.missing.empty() || !report.unexpected.empty() || !report.mismatched.empty())) {
    std::ostringstream message;
    message << "weights do not match the model";
    if (!report.missing.empty()) describe(message, "missing", report.missing);
    if (!report.unexpected.empty()) describe(message, "unexpected", report.unexpected);
    if (!report.mismatched.empty()) describe(message, "mismatched", mismatch_details);
    throw std::runtime_error(message.str());
  }

  torch::NoGradGuard no_grad;
  for (const std::string& name : report.loaded) {
    at::Tensor& target = targets.at(name);
    const at::Tensor& source = tensors.at(name);
    if (storage == LoadStorage::kShare && source.dtype() == target.dtype() &&
        source.device() == target.device())
      target.set_data(source);
    else
      target.copy_(source);
  }
  return report;
}

}  // namespace omnipoint::model
