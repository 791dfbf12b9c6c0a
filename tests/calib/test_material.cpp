// Materials: the custom-material constructors invert each other, and the
// Table I entries are self-consistent to the precision the paper prints.
#include "physics/material.h"

#include <gtest/gtest.h>

using namespace calib::physics;

TEST(Material, ElasticAndSpeedFormsInvertEachOther)
{
    Material a = material_from_elastic(2700.0, 70e9, 0.33);
    Material b = material_from_speeds(a.density_kg_m3, a.cl_m_s, a.ct_m_s);
    EXPECT_NEAR(b.youngs_pa / a.youngs_pa, 1.0, 1e-12);
    EXPECT_NEAR(b.poisson, a.poisson, 1e-12);
}

TEST(Material, TableIIsConsistentWithItsSpeeds)
{
    // E and nu recomputed from the printed c_L, c_T and rho agree with the
    // printed E and nu to the 3 digits the seed gives.
    for (const Material &m : builtin_materials()) {
        Material r = material_from_speeds(m.density_kg_m3, m.cl_m_s, m.ct_m_s);
        EXPECT_NEAR(r.youngs_pa / m.youngs_pa, 1.0, 1e-3) << m.name;
        EXPECT_NEAR(r.poisson, m.poisson, 5e-3) << m.name;
    }
}

TEST(Material, RejectsNonPhysicalInput)
{
    EXPECT_THROW(material_from_elastic(1000, 1e9, 0.5), std::invalid_argument);
    EXPECT_THROW(material_from_speeds(1000, 1000, 900), std::invalid_argument);
    EXPECT_FALSE(find_material("unobtainium"));
    EXPECT_EQ(known_material_names(), "acrylic, glass, steel");
}
