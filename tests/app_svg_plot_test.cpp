// The reports' inline SVG: a bar chart's bars stand on the axis and are as tall as their values
// say, in the plot's own scale; what cannot be drawn is refused, naming it.

#include "svg_plot.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "app.hpp"

namespace {

/// The value of attribute name in the first element at or after from.
double attribute(const std::string& svg, const std::string& name, std::size_t from) {
  const std::size_t at = svg.find(" " + name + "=\"", from);
  EXPECT_NE(at, std::string::npos) << name;
  return std::stod(svg.substr(at + name.size() + 3));
}

TEST(SvgBarChart, BarsStandOnTheAxisAsTallAsTheirValues) {
  const Eigen::Vector3d first(1.0, 2.0, 4.0), second(0.5, 0.0, 3.0);
  const std::string svg = sid::app::svg_bar_chart(
      {"a", "b", "c"}, {{"first", "#111", first}, {"second", "#222", second}}, "RMS [N m]");
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_EQ(svg.substr(svg.size() - 6), "</svg>");
  // One bar per positive value (second's 0 draws none), each with its value as a tooltip.
  std::vector<double> heights, bottoms;
  for (std::size_t at = svg.find("<rect"); at != std::string::npos;
       at = svg.find("<rect", at + 1)) {
    if (svg[svg.find('>', at) - 1] == '/') continue;  // the frame or a legend swatch
    heights.push_back(attribute(svg, "height", at));
    bottoms.push_back(attribute(svg, "y", at) + heights.back());
  }
  ASSERT_EQ(heights.size(), 5u) << svg;
  for (const double bottom : bottoms) EXPECT_NEAR(bottom, bottoms.front(), 0.11);
  // In file order: first's 1, 2, 4, then second's 0.5 and 3.
  const double unit = heights[0];
  EXPECT_NEAR(heights[1], 2.0 * unit, 0.11);
  EXPECT_NEAR(heights[2], 4.0 * unit, 0.11);
  EXPECT_NEAR(heights[3], 0.5 * unit, 0.11);
  EXPECT_NEAR(heights[4], 3.0 * unit, 0.11);
  EXPECT_NE(svg.find("<title>second, c: 3</title>"), std::string::npos) << svg;
  for (const char* label : {">a<", ">b<", ">c<", ">first<", ">second<", ">RMS [N m]<"})
    EXPECT_NE(svg.find(label), std::string::npos) << label;
}

TEST(SvgBarChart, RefusesSeriesThatDoNotMatchTheCategories) {
  try {
    (void)sid::app::svg_bar_chart({"a", "b"}, {{"short", "#111", Eigen::VectorXd::Ones(1)}}, "y");
    ADD_FAILURE() << "a series of 1 value for 2 categories was drawn";
  } catch (const sid::app::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'short' has 1 values for 2 categories"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW((void)sid::app::svg_bar_chart({}, {}, "y"), sid::app::InputError);
}

}  // namespace
