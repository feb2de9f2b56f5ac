// EuRoC sensor.yaml reading and writing (yaml-cpp; cv::FileStorage rejects the EuRoC files,
// which lack the "%YAML:1.0" header it wants, and reports errors without line numbers).
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <sstream>

#include "pl_slam/io/euroc.h"
#include "pl_slam/io/text_util.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

// "<path>:<line>: <key>: <what>" using the node's position when it has one.
[[noreturn]] void Fail(const std::string& path, const YAML::Node& node, const std::string& key,
                       const std::string& what) {
  std::string where = path;
  if (node.IsDefined() && node.Mark().line >= 0)
    where += ":" + std::to_string(node.Mark().line + 1);
  throw InputError(where + ": " + key + ": " + what);
}

YAML::Node Require(const YAML::Node& root, const std::string& key, const std::string& path) {
  YAML::Node node = root[key];
  if (!node.IsDefined() || node.IsNull()) throw InputError(path + ": missing key '" + key + "'");
  return node;
}

std::string Describe(const YAML::Node& node) {
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list of " + std::to_string(node.size());
  if (node.IsMap()) return "a map";
  return "nothing";
}

double Number(const YAML::Node& node, const std::string& key, const std::string& path) {
  double v = 0.0;
  if (!node.IsScalar() || !text::ParseDouble(node.Scalar(), &v)) {
    Fail(path, node, key, Describe(node) + " is not a finite number");
  }
  return v;
}

// A flow or block list of exactly one of `counts` numbers.
std::vector<double> Numbers(const YAML::Node& node, const std::string& key, const std::string& path,
                            std::initializer_list<std::size_t> counts,
                            const std::string& expected) {
  if (!node.IsSequence())
    Fail(path, node, key, "expected a list " + expected + ", found " + Describe(node));
  bool count_ok = false;
  for (std::size_t c : counts) count_ok = count_ok || node.size() == c;
  if (!count_ok) {
    Fail(path, node, key,
         "expected " + expected + ", found " + std::to_string(node.size()) + " values");
  }
  std::vector<double> out;
  for (std::size_t i = 0; i < node.size(); ++i) {
    double v = 0.0;
    const YAML::Node item = node[i];
    if (!item.IsScalar() || !text::ParseDouble(item.Scalar(), &v)) {
      Fail(path, item, key,
           "value " + std::to_string(i + 1) + " (" + Describe(item) + ") is not a finite number");
    }
    out.push_back(v);
  }
  return out;
}

std::string NumberList(const std::vector<double>& values) {
  std::string out = "[";
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i > 0) out += ", ";
    out += text::FormatDouble(values[i]);
  }
  return out + "]";
}

}  // namespace

cv::Matx33d RawCameraCalibration::K() const {
  return cv::Matx33d(fu, 0.0, cu, 0.0, fv, cv, 0.0, 0.0, 1.0);
}

bool RawCameraCalibration::HasDistortion() const {
  for (double d : distortion) {
    if (d != 0.0) return true;
  }
  return false;
}

std::string RawCameraCalibration::Validate() const {
  std::ostringstream os;
  auto bad = [](double v) { return !std::isfinite(v); };
  if (width <= 0 || height <= 0) {
    os << "resolution: " << width << "x" << height << " must be positive";
  } else if (bad(fu) || fu <= 0.0 || bad(fv) || fv <= 0.0) {
    os << "intrinsics: fu=" << fu << ", fv=" << fv << " must be positive";
  } else if (bad(cu) || cu < 0.0 || cu > width || bad(cv) || cv < 0.0 || cv > height) {
    os << "intrinsics: principal point (" << cu << ", " << cv << ") must lie inside the " << width
       << "x" << height << " image";
  } else if (!(distortion.empty() || distortion.size() == 4 || distortion.size() == 5)) {
    os << "distortion_coefficients: expected 4 or 5 values (k1 k2 p1 p2 [k3]), found "
       << distortion.size();
  } else if (!T_b_s.IsFinite()) {
    os << "T_BS: not finite";
  }
  return os.str();
}

RawCameraCalibration ReadEurocCameraYaml(const std::string& path) {
  return ParseEurocCameraYaml(text::ReadFile(path), path);
}

RawCameraCalibration ParseEurocCameraYaml(const std::string& file_content,
                                          const std::string& path) {
  std::string content = file_content;
  // OpenCV-style files start with "%YAML:1.0", which is not a valid YAML directive; comment it
  // out (keeping line numbers) so yaml-cpp parses both flavours.
  if (content.rfind("%YAML:", 0) == 0) content.insert(0, "#");

  YAML::Node loaded;
  try {
    loaded = YAML::Load(content);
  } catch (const YAML::Exception& e) {
    throw InputError(path + ":" + std::to_string(e.mark.line + 1) + ": malformed YAML (" + e.msg +
                     ")");
  }
  // Const access only: yaml-cpp's non-const operator[] would insert missing keys.
  const YAML::Node root = loaded;
  if (!root.IsMap()) throw InputError(path + ": malformed sensor.yaml (expected a map of keys)");

  RawCameraCalibration c;
  c.source = path;
  try {
    if (root["camera_model"].IsDefined()) {
      const YAML::Node m = root["camera_model"];
      if (!m.IsScalar() || text::ToLower(m.Scalar()) != "pinhole") {
        Fail(path, m, "camera_model", Describe(m) + " is not supported (expected pinhole)");
      }
    }

    const auto res =
        Numbers(Require(root, "resolution", path), "resolution", path, {2}, "[width, height]");
    const YAML::Node res_node = root["resolution"];
    if (res[0] != std::floor(res[0]) || res[1] != std::floor(res[1]) || res[0] <= 0 ||
        res[1] <= 0 || res[0] > 100000 || res[1] > 100000) {
      Fail(path, res_node, "resolution",
           "[" + text::FormatDouble(res[0]) + ", " + text::FormatDouble(res[1]) +
               "] must be two positive integers");
    }
    c.width = static_cast<int>(res[0]);
    c.height = static_cast<int>(res[1]);

    const YAML::Node intr_node = Require(root, "intrinsics", path);
    const auto intr = Numbers(intr_node, "intrinsics", path, {4}, "[fu, fv, cu, cv]");
    c.fu = intr[0];
    c.fv = intr[1];
    c.cu = intr[2];
    c.cv = intr[3];

    std::string model = "radial-tangential";
    if (root["distortion_model"].IsDefined()) {
      const YAML::Node m = root["distortion_model"];
      model = m.IsScalar() ? text::ToLower(m.Scalar()) : "";
      if (model == "radtan" || model == "plumb_bob") model = "radial-tangential";
      if (model != "radial-tangential" && model != "none") {
        Fail(path, m, "distortion_model",
             Describe(m) + " is not supported (expected radial-tangential or none)");
      }
    }
    const YAML::Node dist_node = root["distortion_coefficients"];
    if (model == "none") {
      if (dist_node.IsDefined() && !dist_node.IsNull()) {
        c.distortion = Numbers(dist_node, "distortion_coefficients", path, {0, 4, 5},
                               "no values for distortion_model none");
      }
      if (c.HasDistortion()) {
        Fail(path, dist_node, "distortion_coefficients", "must be zero with distortion_model none");
      }
      c.distortion.clear();
    } else {
      c.distortion = Numbers(Require(root, "distortion_coefficients", path),
                             "distortion_coefficients", path, {4, 5}, "[k1, k2, p1, p2(, k3)]");
    }

    const YAML::Node tbs = Require(root, "T_BS", path);
    const YAML::Node data = tbs.IsMap() ? tbs["data"] : tbs;
    if (tbs.IsMap()) {
      for (const char* dim : {"rows", "cols"}) {
        if (tbs[dim].IsDefined() && Number(tbs[dim], std::string("T_BS.") + dim, path) != 4.0) {
          Fail(path, tbs[dim], std::string("T_BS.") + dim, "must be 4");
        }
      }
      if (!data.IsDefined()) throw InputError(path + ": missing key 'T_BS.data'");
    }
    const auto m = Numbers(data, "T_BS.data", path, {16}, "16 numbers (row-major 4x4)");
    Eigen::Matrix4d T;
    for (int r = 0; r < 4; ++r) {
      for (int col = 0; col < 4; ++col) T(r, col) = m[4 * r + col];
    }
    const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
    const double ortho_err =
        (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    const double row_err = (T.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff();
    if (ortho_err > 1e-4 || R.determinant() <= 0.0 || row_err > 1e-9) {
      std::ostringstream os;
      os << "not a rigid transform (|R^T R - I| = " << ortho_err << ", det R = " << R.determinant()
         << ", last row error " << row_err << ")";
      Fail(path, data, "T_BS", os.str());
    }
    c.T_b_s = SE3::FromMatrix(T);

    if (root["rate_hz"].IsDefined()) {
      c.rate_hz = Number(root["rate_hz"], "rate_hz", path);
      if (c.rate_hz <= 0.0) Fail(path, root["rate_hz"], "rate_hz", "must be positive");
    }
  } catch (const YAML::Exception& e) {
    throw InputError(path + ":" + std::to_string(e.mark.line + 1) + ": malformed sensor.yaml (" +
                     e.msg + ")");
  }

  const std::string err = c.Validate();
  if (!err.empty()) throw InputError(path + ": " + err);
  return c;
}

std::string FormatEurocCameraYaml(const RawCameraCalibration& calib, const std::string& comment) {
  const Eigen::Matrix4d T = calib.T_b_s.matrix();
  std::ostringstream os;
  os << "# General sensor definitions.\n"
     << "sensor_type: camera\n"
     << "comment: " << comment << "\n\n"
     << "# Sensor extrinsics wrt. the body-frame.\n"
     << "T_BS:\n  cols: 4\n  rows: 4\n  data: [";
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      if (r > 0 || c > 0) os << (c == 0 ? ",\n         " : ", ");
      os << text::FormatDouble(T(r, c));
    }
  }
  os << "]\n\n# Camera specific definitions.\n";
  if (calib.rate_hz > 0.0) os << "rate_hz: " << text::FormatDouble(calib.rate_hz) << "\n";
  os << "resolution: [" << calib.width << ", " << calib.height << "]\n"
     << "camera_model: pinhole\n"
     << "intrinsics: " << NumberList({calib.fu, calib.fv, calib.cu, calib.cv})
     << " #fu, fv, cu, cv\n"
     << "distortion_model: radial-tangential\n"
     << "distortion_coefficients: "
     << NumberList(calib.distortion.empty() ? std::vector<double>{0.0, 0.0, 0.0, 0.0}
                                            : calib.distortion)
     << "\n";
  return os.str();
}

}  // namespace pl_slam
