#pragma once
// Test-only helpers: reading the reference CSV files in tests/data/.

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid_test {

inline std::string data_path(const std::string& name) {
  return std::string(SID_TEST_DATA_DIR) + "/" + name;
}

/// The whole text of a file in tests/data/ (a URDF, a YAML), "" if it cannot be read.
inline std::string read_text(const std::string& name) {
  std::ifstream in(data_path(name));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// A numeric CSV table: header names, data (rows x columns) and the '#' comment lines.
struct Table {
  std::vector<std::string> names;
  Eigen::MatrixXd data;
  std::vector<std::string> comments;

  Eigen::Index column(const std::string& name) const {
    for (std::size_t j = 0; j < names.size(); ++j)
      if (names[j] == name) return static_cast<Eigen::Index>(j);
    throw std::runtime_error("test data has no column " + name);
  }
  Eigen::VectorXd col(const std::string& name) const { return data.col(column(name)); }
};

inline Table read_table(const std::string& name) {
  std::ifstream in(data_path(name));
  if (!in) throw std::runtime_error("cannot open test data " + data_path(name));
  Table table;
  std::vector<std::vector<double>> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (line[0] == '#') {
      table.comments.push_back(line);
      continue;
    }
    std::stringstream ss(line);
    std::string cell;
    if (table.names.empty()) {
      while (std::getline(ss, cell, ',')) table.names.push_back(cell);
      continue;
    }
    std::vector<double> row;
    while (std::getline(ss, cell, ',')) row.push_back(std::stod(cell));
    rows.push_back(row);
  }
  table.data.resize(static_cast<Eigen::Index>(rows.size()),
                    static_cast<Eigen::Index>(table.names.size()));
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (std::size_t j = 0; j < rows[i].size(); ++j)
      table.data(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = rows[i][j];
  return table;
}

/// The value of key=value in a comment line such as "# case=x n=5 p=2.53".
inline double comment_value(const Table& table, const std::string& key) {
  for (const auto& c : table.comments) {
    const auto pos = c.find(" " + key + "=");
    if (pos != std::string::npos) return std::stod(c.substr(pos + key.size() + 2));
  }
  throw std::runtime_error("test data has no comment value " + key);
}

/// Expects f to throw std::invalid_argument whose message starts with prefix and mentions word.
template <typename F>
void expect_invalid_argument(F f, const std::string& prefix, const std::string& word) {
  try {
    f();
    ADD_FAILURE() << "no exception, expected " << prefix;
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(prefix, 0), 0u) << what;
    EXPECT_NE(what.find(word), std::string::npos) << what;
  }
}

}  // namespace sid_test
